#include "core/heartbeat.hpp"

#include <algorithm>

#include "core/protocol.hpp"
#include "core/node.hpp"

namespace cansim {

namespace {
using cob::kErrorControlBase;
constexpr std::uint8_t kBootUpState = 0x00;

std::uint8_t producer_of(std::uint32_t v) { return std::uint8_t(v >> 16); }
std::uint16_t time_of(std::uint32_t v) { return std::uint16_t(v); }
bool in_use(std::uint32_t v) { return producer_of(v) != 0 && time_of(v) != 0; }
}  // namespace

void Heartbeat::reset(TimeUs) {
  const OdEntry* p = node_.od().find(0x1017, 0);
  period_ms_ = p ? std::uint16_t(node_.values().get_u(*p)) : 0;
  next_beat_ = kNever;  // the producer starts at the boot-up
  failed_count_ = 0;
  const OdObject* obj = node_.od().object(0x1016);
  std::size_t subs = obj && obj->count > 0 ? obj->count - 1u : 0u;
  if (consumers_.size() != subs) consumers_.assign(subs, Consumer{});
  for (std::size_t i = 0; i < subs; ++i) {
    consumers_[i] = Consumer{};
    if (const OdEntry* e = node_.od().find(*obj, std::uint8_t(i + 1)))
      configure(consumers_[i], std::uint32_t(node_.values().get_u(*e)));
  }
  update_deadline();
}

void Heartbeat::start(TimeUs now) {
  next_beat_ = period_ms_ ? now + node_.local_duration(ms(period_ms_)) : kNever;
  update_deadline();
}

void Heartbeat::configure(Consumer& c, std::uint32_t value) {
  c.node_id = producer_of(value);
  c.time_ms = time_of(value);
  c.watch = in_use(value) ? Watch::kWaiting : Watch::kOff;
  c.deadline = kNever;
}

void Heartbeat::process(TimeUs now) {
  if (next_beat_ <= now) {
    if (node_.state() != NmtState::kInitialising && !producer_stopped_)
      node_.send(CanFrame::make(kErrorControlBase + node_.node_id(), {std::uint8_t(node_.state())}));
    // Absolute schedule: the next multiple of the period (on the node's
    // own clock: clock_drift) after now.
    TimeUs period = node_.local_duration(ms(period_ms_));
    next_beat_ += period * ((now - next_beat_) / period + 1);
  }
  for (Consumer& c : consumers_)
    if (c.watch == Watch::kActive && c.deadline <= now) time_out(c, now);
  update_deadline();
}

void Heartbeat::time_out(Consumer& c, TimeUs now) {
  c.watch = Watch::kTimedOut;
  c.deadline = kNever;
  if (failed_count_++ == 0 && !node_.guarding().life_guard_failed()) {
    if (std::int64_t code = node_.options().heartbeat_consumer_emcy)
      node_.emcy().raise(std::uint16_t(code), 0, nullptr, now);
  }
  node_.nmt().communication_error(now);
}

void Heartbeat::on_heartbeat(Consumer& c, std::uint8_t state, TimeUs now) {
  bool recovered = c.watch == Watch::kTimedOut;
  if (state == kBootUpState) {
    // A boot-up does not start monitoring; it re-arms the entry (CiA 301).
    c.watch = Watch::kWaiting;
    c.deadline = kNever;
  } else {
    c.watch = Watch::kActive;
    c.deadline = now + node_.local_duration(ms(c.time_ms));
  }
  if (recovered && --failed_count_ == 0 && !node_.guarding().life_guard_failed()) {
    if (std::int64_t code = node_.options().heartbeat_consumer_emcy) node_.emcy().clear(std::uint16_t(code), now);
  }
}

bool Heartbeat::on_frame(const CanFrame& f, TimeUs now) {
  if (f.rtr() || f.extended() || f.dlc < 1) return false;
  if (f.id <= kErrorControlBase || f.id > kErrorControlBase + 127) return false;
  if (node_.state() == NmtState::kInitialising) return false;
  std::uint8_t producer = std::uint8_t(f.id - kErrorControlBase);
  bool mine = false;
  for (Consumer& c : consumers_) {
    if (c.watch == Watch::kOff || c.node_id != producer) continue;
    on_heartbeat(c, f.data[0] & kNmtStateBits, now);
    mine = true;
  }
  if (mine) update_deadline();
  return mine;
}

void Heartbeat::update_deadline() {
  TimeUs t = next_beat_;
  for (const Consumer& c : consumers_)
    if (c.watch == Watch::kActive) t = std::min(t, c.deadline);
  next_ = t;
}

void Heartbeat::collect_rx_ids(std::vector<std::uint32_t>& out) const {
  for (const Consumer& c : consumers_)
    if (c.watch != Watch::kOff) out.push_back(kErrorControlBase + c.node_id);
}

bool Heartbeat::owns(std::uint16_t index) const { return index == 0x1016 || index == 0x1017; }

SdoAbort Heartbeat::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  std::uint64_t v = decode_u(e.type, data.data());
  if (e.index == 0x1017) {
    node_.values().set_bytes(e, data);
    period_ms_ = std::uint16_t(v);
    // A new value restarts the period (CiA 301 §7.5.2.30).
    next_beat_ = kNever;
    if (node_.nmt().booted()) start(now);
    update_deadline();
    return SdoAbort::kNone;
  }
  if (e.sub == 0 || e.sub > consumers_.size()) {
    node_.values().set_bytes(e, data);
    return SdoAbort::kNone;
  }
  std::uint32_t value = std::uint32_t(v);
  if ((value >> 24) != 0 || producer_of(value) > 127) return SdoAbort::kInvalidValue;
  // Two active entries must not watch the same node (CiA 301 §7.5.2.29).
  if (in_use(value)) {
    for (std::size_t i = 0; i < consumers_.size(); ++i) {
      const Consumer& other = consumers_[i];
      if (i + 1 != e.sub && other.watch != Watch::kOff && other.node_id == producer_of(value))
        return SdoAbort::kParamIncompatible;
    }
  }
  Consumer& c = consumers_[e.sub - 1];
  if (c.watch == Watch::kTimedOut && --failed_count_ == 0 && !node_.guarding().life_guard_failed()) {
    if (std::int64_t code = node_.options().heartbeat_consumer_emcy) node_.emcy().clear(std::uint16_t(code), now);
  }
  node_.values().set_bytes(e, data);
  configure(c, value);
  update_deadline();
  node_.rx_changed();
  return SdoAbort::kNone;
}

}  // namespace cansim
