#include "core/nmt.hpp"

#include "core/protocol.hpp"
#include "core/node.hpp"

#include <algorithm>

namespace cansim {

namespace {
using cob::kErrorControlBase;
}  // namespace

void NmtSlave::power_on(TimeUs now) { restart(ResetKind::kPowerOn, now); }

void NmtSlave::reboot_keeping_values(TimeUs now) { restart(ResetKind::kCommunication, now, false); }

void NmtSlave::restart(ResetKind kind, TimeUs now, bool reload) {
  set_state(NmtState::kInitialising, now);
  booted_ = false;
  ++resets_;
  if (reload) {
    node_.prepare_reset(kind, now);
    node_.reset_values(kind);
  }
  node_.reset_services(now);  // includes reset() below: builds plan_
  if (Application* app = node_.app()) app->on_reset(node_, kind, now);
  if (node_.node_id() == lss::kUnconfiguredNodeId) return;  // waits for LSS (CiA 305)
  boot_at_ = now + plan_.boot_up_delay;
  update_deadline();
  if (boot_at_ <= now) process(now);
}

void NmtSlave::reset(TimeUs) {
  const NodeOptions& o = node_.options();
  plan_ = BootPlan{};
  boot_time_.set(ms(o.boot_up_delay_ms), ms(o.boot_up_jitter_ms));
  plan_.boot_up_delay = boot_time_.next(node_.seed());
  plan_.self_start = o.nmt_auto_start;
  plan_.self_start_delay = ms(o.nmt_auto_start_delay_ms);
  plan_.start_all_delay = o.nmt_start_all_delay_ms < 0 ? -1 : ms(o.nmt_start_all_delay_ms);
  // 0x1F80 NMT start-up (CiA 302-2), read the way the profile's options say.
  if (const OdEntry* e = node_.od().find(0x1F80, 0)) {
    std::uint64_t v = node_.values().get_u(*e);
    std::uint64_t mask = std::uint64_t(o.nmt_startup_self_start_mask);
    bool hit = (v & mask) != 0;
    if (o.nmt_startup_self_start_if_clear ? !hit : hit) plan_.self_start = true;
    if ((v & std::uint64_t(o.nmt_startup_start_all_mask)) && plan_.start_all_delay < 0) plan_.start_all_delay = 0;
  }
  boot_at_ = start_at_ = start_all_at_ = kNever;
  update_deadline();
}

void NmtSlave::boot_up(TimeUs now) {
  boot_at_ = kNever;
  booted_ = true;
  if (plan_.send_boot_up) send_boot_up(now);
  node_.heartbeat().start(now);  // first heartbeat one period after the boot-up
  set_state(NmtState::kPreOperational, now);
  if (plan_.self_start) start_at_ = now + plan_.self_start_delay;
  if (plan_.start_all_delay >= 0) start_all_at_ = now + plan_.start_all_delay;
}

void NmtSlave::send_boot_up(TimeUs now) {
  if (!node_.send(CanFrame::make(kErrorControlBase + node_.node_id(), {0x00}))) return;
  if (NodeObserver* o = node_.observer()) o->on_boot_up(node_, now);
}

// Like CANopenNode, a node that sends "start all" applies it to itself too
// (it does not hear its own frame).
void NmtSlave::send_start_all(TimeUs now) {
  start_all_at_ = kNever;
  node_.send(CanFrame::make(cob::kNmt, {kNmtStart, 0x00}));
  command(kNmtStart, now);
}

void NmtSlave::process(TimeUs now) {
  if (boot_at_ <= now) boot_up(now);
  if (start_all_at_ <= now) send_start_all(now);
  if (start_at_ <= now) {
    start_at_ = kNever;
    command(kNmtStart, now);
  }
  update_deadline();
}

void NmtSlave::update_deadline() { next_ = std::min({boot_at_, start_at_, start_all_at_}); }

void NmtSlave::command(std::uint8_t cs, TimeUs now) {
  switch (cs) {
    case kNmtStart: return set_state(NmtState::kOperational, now);
    case kNmtStop: return set_state(NmtState::kStopped, now);
    case kNmtEnterPreOperational: return set_state(NmtState::kPreOperational, now);
    case kNmtResetNode: return restart(ResetKind::kNode, now);
    case kNmtResetCommunication: return restart(ResetKind::kCommunication, now);
    default: return;
  }
}

void NmtSlave::set_state(NmtState s, TimeUs now) {
  if (s == state_) return;
  NmtState old = state_;
  state_ = s;
  // A start / stop command overrides a pending autonomous start.
  if (s != NmtState::kPreOperational) start_at_ = kNever;
  update_deadline();
  node_.nmt_state_changed(old, now);
}

void NmtSlave::communication_error(TimeUs now) {
  const OdEntry* e = node_.od().find(0x1029, 1);
  react(e ? std::int64_t(node_.values().get_u(*e)) : node_.options().comm_error_reaction_without_1029, now);
}

void NmtSlave::error_reaction(std::uint8_t error_class, TimeUs now) {
  if (error_class == 1) return communication_error(now);
  if (const OdEntry* e = node_.od().find(0x1029, error_class)) react(std::int64_t(node_.values().get_u(*e)), now);
}

void NmtSlave::react(std::int64_t reaction, TimeUs now) {
  switch (reaction) {
    case 0:  // pre-operational, only if currently operational
      if (state_ == NmtState::kOperational) set_state(NmtState::kPreOperational, now);
      return;
    case 2: return set_state(NmtState::kStopped, now);
    default:  // 1: no change; 3..255 reserved / manufacturer-specific
      return;
  }
}

// NMT node control: COB-ID 0, DLC 2, [cs, node-ID], node-ID 0 = all nodes.
// Frames of any other length are ignored (CiA 301 §7.2.8.3.1); so is
// everything while INITIALISING.
bool NmtSlave::on_frame(const CanFrame& f, TimeUs now) {
  if (f.id != cob::kNmt || f.rtr() || f.extended()) return false;
  if (f.dlc != 2 || state_ == NmtState::kInitialising) return true;
  std::uint8_t target = f.data[1];
  if (target == 0 || target == node_.node_id()) command(f.data[0], now);
  return true;
}

void NmtSlave::collect_rx_ids(std::vector<std::uint32_t>& out) const { out.push_back(cob::kNmt); }

bool NmtSlave::owns(std::uint16_t index) const { return index == 0x1F80 || index == 0x1029; }

// 0x1029 error behaviour: 0 pre-op, 1 no change, 2 stopped, 3..127 reserved,
// 128..255 manufacturer-specific (CiA 301 §7.5.2.32). 0x1F80 takes effect at
// the next boot (CiA 302-2).
SdoAbort NmtSlave::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  std::uint64_t v = decode_u(e.type, data.data());
  if (e.index == 0x1029 && e.sub != 0 && v > 2 && v < 0x80) return SdoAbort::kInvalidValue;
  if (e.index == 0x1F80 && !node_.options().nmt_startup_values.contains(v)) return SdoAbort::kInvalidValue;
  node_.values().set_bytes(e, data);
  return SdoAbort::kNone;
}

}  // namespace cansim
