#include "core/heartbeat.hpp"

#include "core/node.hpp"

namespace cansim {

void Heartbeat::reset(TimeUs) { next_ = kNever; }
bool Heartbeat::on_frame(const CanFrame&, TimeUs) { return false; }
void Heartbeat::process(TimeUs) {}
void Heartbeat::collect_rx_ids(std::vector<std::uint32_t>&) const {}
bool Heartbeat::owns(std::uint16_t) const { return false; }
SdoAbort Heartbeat::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

}  // namespace cansim
