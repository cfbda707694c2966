#include "core/nmt.hpp"

#include "core/node.hpp"

namespace cansim {

void NmtSlave::power_on(TimeUs now) {
  node_.reset_values(ResetKind::kPowerOn);
  node_.reset_services(now);
  node_.send(CanFrame::make(0x700u + node_.node_id(), {0x00}));
  state_ = NmtState::kPreOperational;
}
void NmtSlave::command(std::uint8_t, TimeUs) {}
void NmtSlave::reset(TimeUs) { next_ = kNever; }
bool NmtSlave::on_frame(const CanFrame&, TimeUs) { return false; }
void NmtSlave::process(TimeUs) {}
void NmtSlave::collect_rx_ids(std::vector<std::uint32_t>&) const {}
bool NmtSlave::owns(std::uint16_t) const { return false; }
SdoAbort NmtSlave::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

}  // namespace cansim
