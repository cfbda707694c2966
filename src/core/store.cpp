#include "core/store.hpp"

#include "core/node.hpp"

namespace cansim {

void StoreRestore::apply_stored(std::uint16_t, std::uint16_t) {}
void StoreRestore::reset(TimeUs) { next_ = kNever; }
bool StoreRestore::on_frame(const CanFrame&, TimeUs) { return false; }
void StoreRestore::process(TimeUs) {}
void StoreRestore::collect_rx_ids(std::vector<std::uint32_t>&) const {}
bool StoreRestore::owns(std::uint16_t) const { return false; }
SdoAbort StoreRestore::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

}  // namespace cansim
