#include "core/guarding.hpp"

#include "core/node.hpp"

namespace cansim {

void NodeGuarding::reset(TimeUs) { next_ = kNever; }
bool NodeGuarding::on_frame(const CanFrame&, TimeUs) { return false; }
void NodeGuarding::process(TimeUs) {}
void NodeGuarding::collect_rx_ids(std::vector<std::uint32_t>&) const {}
bool NodeGuarding::owns(std::uint16_t) const { return false; }
SdoAbort NodeGuarding::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

}  // namespace cansim
