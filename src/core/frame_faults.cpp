#include "core/frame_faults.hpp"

#include <algorithm>

#include "core/node.hpp"

namespace cansim {

bool FrameSelector::by_cob_id() const { return service == TxService::kOther; }

bool FrameSelector::matches(const Node& node, const CanFrame& f) const {
  if (by_cob_id()) return matches_id(f);
  const TxSource src = node.tx_source(f);
  return src.service == service && (service != TxService::kTpdo || src.tpdo == tpdo);
}

bool FrameFaults::set(const FrameFaultRule& rule) {
  for (std::size_t i = 0; i < n_; ++i)
    if (slots_[i].rule.id == rule.id) {
      slots_[i].rule = rule;
      return true;
    }
  if (n_ == kMaxRules) return false;
  slots_[n_++] = Slot{rule, FaultRandom(mix_seed(rule.seed, power_on_)), false, CanFrame{}};
  if (rule.kind == FrameFaultKind::kDelay) reserve_held();
  return true;
}

void FrameFaults::restart(std::uint32_t power_on) {
  power_on_ = power_on;
  for (std::size_t i = 0; i < n_; ++i) slots_[i].random = FaultRandom(mix_seed(slots_[i].rule.seed, power_on));
}

bool FrameFaults::has(std::uint32_t id) const {
  return std::any_of(slots_.begin(), slots_.begin() + std::ptrdiff_t(n_),
                     [&](const Slot& s) { return s.rule.id == id; });
}

void FrameFaults::clear(std::uint32_t id) {
  auto end = std::remove_if(slots_.begin(), slots_.begin() + std::ptrdiff_t(n_),
                            [&](const Slot& s) { return s.rule.id == id; });
  n_ = std::size_t(end - slots_.begin());
}

bool FrameFaults::apply(const Node& node, Pass& p, TimeUs, bool) {
  for (std::size_t i = 0; i < n_; ++i) {
    Slot& s = slots_[i];
    if (!s.rule.select.matches(node, p.frame) || !s.random.chance(s.rule.probability)) continue;
    ++affected_;
    if (!apply_rule(s, p)) return false;
  }
  return true;
}

bool FrameFaults::apply_rx(Pass& p, TimeUs) {
  for (std::size_t i = 0; i < n_; ++i) {
    Slot& s = slots_[i];
    if (!s.rule.select.by_cob_id() || !s.rule.select.matches_id(p.frame) || !s.random.chance(s.rule.probability))
      continue;
    ++affected_;
    if (!apply_rule(s, p)) return false;
  }
  return true;
}

// What one rule does to a frame; false: it is dropped.
bool FrameFaults::apply_rule(Slot& s, Pass& p) {
  const FrameFaultRule& r = s.rule;
  CanFrame& f = p.frame;
  switch (r.kind) {
    case FrameFaultKind::kDrop: return false;
    case FrameFaultKind::kDelay: p.delay += r.delay + s.random.upto(r.jitter); return true;
    case FrameFaultKind::kFreeze:
      if (!s.frozen) {
        s.frozen = true;
        s.frozen_frame = f;
      } else if (!f.rtr()) {
        f.dlc = s.frozen_frame.dlc;
        std::copy(std::begin(s.frozen_frame.data), std::end(s.frozen_frame.data), f.data);
      }
      return true;
    case FrameFaultKind::kCorrupt: {
      if (f.rtr() || f.dlc == 0) return true;
      std::uint8_t bytes = r.bytes;
      if (bytes == 0) bytes = std::uint8_t(1u << s.random.upto(f.dlc - 1));
      for (int i = 0; i < f.dlc && i < 8; ++i) {
        if (!(bytes & (1u << i))) continue;
        if (r.value >= 0) f.data[i] = std::uint8_t(r.value);
        else f.data[i] ^= std::uint8_t(1 + s.random.upto(254));  // at least one bit flips
      }
      return true;
    }
    case FrameFaultKind::kDlc:
      for (int i = f.dlc; i < r.dlc && i < 8; ++i) f.data[i] = 0;
      f.dlc = r.dlc;
      return true;
    case FrameFaultKind::kDuplicate: p.copies = 2; return true;
  }
  return true;
}

// Sorted by time (stable: equal times keep their order).
void FrameFaults::hold(const CanFrame& f, TimeUs at, bool from_outside) {
  reserve_held();
  if (held_n_ == held_.size()) {
    ++overflowed_;
    return;
  }
  std::size_t i = held_n_++;
  for (; i > 0; --i) {
    Held& before = held_[(held_head_ + i - 1) % held_.size()];
    if (before.at <= at) break;
    held_[(held_head_ + i) % held_.size()] = before;
  }
  held_[(held_head_ + i) % held_.size()] = Held{at, f, from_outside};
}

}  // namespace cansim
