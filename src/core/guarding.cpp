#include "core/guarding.hpp"

#include "core/protocol.hpp"
#include "core/node.hpp"

namespace cansim {

using cob::kErrorControlBase;

void NodeGuarding::reset(TimeUs) {
  supported_ = node_.od().find(0x100C, 0) != nullptr;
  toggle_ = false;  // CiA 301: the toggle starts at 0 after reset communication
  failed_ = false;
  next_ = kNever;  // life guarding starts with the first RTR
  read_life_time();
}

void NodeGuarding::read_life_time() {
  const OdEntry* g = node_.od().find(0x100C, 0);
  const OdEntry* f = node_.od().find(0x100D, 0);
  std::uint64_t guard_ms = g ? node_.values().get_u(*g) : 0;
  std::uint64_t factor = f ? node_.values().get_u(*f) : 0;
  life_time_ = ms(std::int64_t(guard_ms * factor));
}

bool NodeGuarding::answers() const {
  if (!supported_ || node_.state() == NmtState::kInitialising) return false;
  return node_.heartbeat().producer_time_ms() == 0 || node_.options().guarding_with_heartbeat;
}

bool NodeGuarding::on_frame(const CanFrame& f, TimeUs now) {
  if (!f.rtr() || f.extended() || f.id != kErrorControlBase + node_.node_id()) return false;
  if (!answers()) return true;
  std::uint8_t byte = std::uint8_t(std::uint8_t(node_.state()) | (toggle_ ? kGuardingToggle : 0x00));
  toggle_ = !toggle_;
  node_.send(CanFrame::make(kErrorControlBase + node_.node_id(), {byte}));
  next_ = life_time_ > 0 ? now + node_.local_duration(life_time_) : kNever;
  if (failed_) {
    failed_ = false;
    std::int64_t code = node_.options().heartbeat_consumer_emcy;
    if (code && !node_.heartbeat().consumer_failed()) node_.emcy().clear(std::uint16_t(code), now);
  }
  return true;
}

// Life-guarding event (CiA 301 §7.2.8.3.1): the master stopped guarding us.
void NodeGuarding::process(TimeUs now) {
  next_ = kNever;
  if (failed_) return;
  failed_ = true;
  std::int64_t code = node_.options().heartbeat_consumer_emcy;
  if (code && !node_.heartbeat().consumer_failed()) node_.emcy().raise(std::uint16_t(code), 0, nullptr, now);
  node_.nmt().communication_error(now);
}

void NodeGuarding::collect_rx_ids(std::vector<std::uint32_t>& out) const {
  if (supported_) out.push_back(kErrorControlBase + node_.node_id());
}

bool NodeGuarding::owns(std::uint16_t index) const { return index == 0x100C || index == 0x100D; }

// A new guard time / factor applies from the next RTR on.
SdoAbort NodeGuarding::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  node_.values().set_bytes(e, data);
  read_life_time();
  if (life_time_ == 0) next_ = kNever;
  return SdoAbort::kNone;
}

}  // namespace cansim
