#include "io/dispatch.hpp"

#include <algorithm>

#include "core/protocol.hpp"

namespace cansim::io {

std::uint32_t RxDispatch::key_of(std::uint32_t rx_id) {
  std::uint32_t id = rx_id & cob::kId29Mask;
  bool extended = (rx_id & (cob::kRxIdExtended | cob::kFrame29Bit)) || id > cob::kId11Mask;
  return extended ? (id | kExtendedKey) : id;
}

std::vector<std::uint32_t>& RxDispatch::list(std::uint32_t key) {
  if (key & kExtendedKey) return extended_[key];
  return standard_[key];
}

void RxDispatch::unlink(std::uint32_t slot, std::uint32_t key) {
  if (key & kExtendedKey) {
    auto it = extended_.find(key);
    if (it == extended_.end()) return;
    std::erase(it->second, slot);
    if (it->second.empty()) extended_.erase(it);
    return;
  }
  std::erase(standard_[key], slot);
}

void RxDispatch::set(std::uint32_t slot, std::span<const std::uint32_t> rx_ids) {
  remove(slot);
  if (by_slot_.size() <= slot) by_slot_.resize(slot + 1);
  auto& mine = by_slot_[slot];
  for (std::uint32_t id : rx_ids) mine.push_back(key_of(id));
  std::sort(mine.begin(), mine.end());
  mine.erase(std::unique(mine.begin(), mine.end()), mine.end());
  for (std::uint32_t key : mine) list(key).push_back(slot);
}

void RxDispatch::remove(std::uint32_t slot) {
  if (slot >= by_slot_.size()) return;
  for (std::uint32_t key : by_slot_[slot]) unlink(slot, key);
  by_slot_[slot].clear();
}

std::span<const std::uint32_t> RxDispatch::lookup(const CanFrame& frame) const {
  if (!frame.extended())
    return frame.id <= cob::kId11Mask ? std::span<const std::uint32_t>(standard_[frame.id])
                                      : std::span<const std::uint32_t>();
  auto it = extended_.find((frame.id & cob::kId29Mask) | kExtendedKey);
  if (it == extended_.end()) return {};
  return it->second;
}

std::span<const std::uint32_t> RxDispatch::registered(std::uint32_t slot) const {
  if (slot >= by_slot_.size()) return {};
  return by_slot_[slot];
}

}  // namespace cansim::io
