#include "core/sdo_server.hpp"

#include "core/node.hpp"

namespace cansim {

void SdoServer::reset(TimeUs) { next_ = kNever; }
bool SdoServer::on_frame(const CanFrame&, TimeUs) { return false; }
void SdoServer::process(TimeUs) {}
void SdoServer::collect_rx_ids(std::vector<std::uint32_t>&) const {}
bool SdoServer::owns(std::uint16_t) const { return false; }
SdoAbort SdoServer::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

}  // namespace cansim
