#include "core/sync.hpp"

#include "core/node.hpp"

namespace cansim {

void SyncConsumer::reset(TimeUs) { next_ = kNever; }
bool SyncConsumer::on_frame(const CanFrame&, TimeUs) { return false; }
void SyncConsumer::process(TimeUs) {}
void SyncConsumer::collect_rx_ids(std::vector<std::uint32_t>&) const {}
bool SyncConsumer::owns(std::uint16_t) const { return false; }
SdoAbort SyncConsumer::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

}  // namespace cansim
