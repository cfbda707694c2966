#include "core/lss_slave.hpp"

#include "core/node.hpp"

namespace cansim {

void LssSlave::reset(TimeUs) { next_ = kNever; }
bool LssSlave::on_frame(const CanFrame&, TimeUs) { return false; }
void LssSlave::process(TimeUs) {}
void LssSlave::collect_rx_ids(std::vector<std::uint32_t>&) const {}
bool LssSlave::owns(std::uint16_t) const { return false; }
SdoAbort LssSlave::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

}  // namespace cansim
