#include "core/pdo.hpp"

#include "core/node.hpp"

namespace cansim {

void PdoEngine::reset(TimeUs) { next_ = kNever; }
bool PdoEngine::on_frame(const CanFrame&, TimeUs) { return false; }
void PdoEngine::process(TimeUs) {}
void PdoEngine::collect_rx_ids(std::vector<std::uint32_t>&) const {}
bool PdoEngine::owns(std::uint16_t) const { return false; }
void PdoEngine::on_sync(std::uint8_t, TimeUs) {}
void PdoEngine::raise_event(unsigned) {}
void PdoEngine::raise_event_for(const OdEntry&) {}
SdoAbort PdoEngine::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

}  // namespace cansim
