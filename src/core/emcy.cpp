#include "core/emcy.hpp"

#include "core/node.hpp"

namespace cansim {

void Emcy::reset(TimeUs) { next_ = kNever; }
bool Emcy::on_frame(const CanFrame&, TimeUs) { return false; }
void Emcy::process(TimeUs) {}
void Emcy::collect_rx_ids(std::vector<std::uint32_t>&) const {}
bool Emcy::owns(std::uint16_t) const { return false; }
SdoAbort Emcy::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

}  // namespace cansim
