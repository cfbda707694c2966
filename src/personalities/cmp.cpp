#include "personalities/cmp.hpp"

#include <algorithm>
#include <cstring>

#include "core/protocol.hpp"

namespace cansim::personalities::cmp {

namespace {

constexpr unsigned kPdoCount = CmpApplication::kPdoCount;
constexpr unsigned kMaxMode = model::CmpSettings::kMaxMode;
constexpr unsigned kMaxEntries = model::CmpSettings::kMaxEntries;  // 0x1A0x subs 1..4

// Vendor objects (0x2001 is printed in the manual, the rest are placeholders).
constexpr std::uint16_t kBaudRate = 0x2001;
constexpr std::uint16_t kMappingMode = 0x2100;
constexpr std::uint16_t kAutoStart = 0x2200;
constexpr std::uint16_t kEventMask = 0x2201;
constexpr std::uint16_t kSpecialMessages = 0x2210;  // P 0x2210..13, T 0x2214..17
constexpr std::uint16_t kLimitEventType = 0x2220;
constexpr std::uint16_t kLastNodeError = 0x2230;
constexpr std::uint16_t kNodeSubError = 0x2231;
constexpr std::uint16_t kMsCounter = 0x2240;
constexpr std::uint16_t kActualMessage = 0x2245;  // P 0x2245, T 0x2246

// LimitEventType values; special message object = kSpecialMessages + 4 * channel + value - 1.
enum : std::uint8_t { kNoLimitEvent, kLowerLimitUp, kLowerLimitDown, kUpperLimitUp, kUpperLimitDown };

// EMCY codes of the "Permanent Autotest" (manual, Error Messages).
constexpr std::uint16_t kEmcyDeviceTemperature = 0x4200;
constexpr std::uint16_t kEmcyDataSet = 0x6300;
constexpr std::uint16_t kSubUserPageChecksums = 0x0030;  // EEPromUser{Comm,Appl}Page_Checksum
constexpr std::size_t kSubCodeOffset = 3;                // NodeSubErrorCode in EMCY bytes 6-7

constexpr std::uint16_t kBitRatesKbit[10] = {1000, 800, 500, 250, 125, 100, 50, 20, 10, 0};  // 9 = automatic

using MappingMode = Settings::MappingMode;

int bit_rate_index(std::uint64_t kbit) {
  for (int i = 0; i < 10; ++i)
    if (kBitRatesKbit[i] == kbit) return i;
  return -1;
}

// EventMask bits (manual "EventMask-Bit-Allocation"): P lower 0, P upper 1,
// T lower 2, T upper 3, P delta 4, T delta 5.
std::uint8_t lower_bit(physics::Channel c) { return c == physics::Channel::Pressure ? 0x01 : 0x04; }
std::uint8_t upper_bit(physics::Channel c) { return c == physics::Channel::Pressure ? 0x02 : 0x08; }
std::uint8_t delta_bit(physics::Channel c) { return c == physics::Channel::Pressure ? 0x10 : 0x20; }

}  // namespace

void CmpApplication::on_reset(Node& node, ResetKind kind, TimeUs now) {
  SensorApplication::on_reset(node, kind, now);
  if (kind != ResetKind::kCommunication) apply_baud_rate(node);
  for (unsigned n = 1; n <= kPdoCount; ++n) apply_mapping_mode(node, n, false, now);
  state_ = State{};
  state_.auto_start = node.values().u(kAutoStart, 0) == 1;
  if (kind != ResetKind::kCommunication) self_test_at_start_up(node, now);
  // Auto-Start: OPERATIONAL after initialisation (NMT section); 0x1F80 bit 3
  // is read by the core. A start-up fault holds the node in (AUTO-)PRE-OPERATIONAL.
  const bool fault = node.emcy().active_count() != 0;
  BootPlan& plan = node.nmt().boot_plan();
  plan.self_start = !fault && (plan.self_start || state_.auto_start);
  state_.auto_resume = state_.auto_start && fault;
}

void CmpApplication::on_nmt_state(Node& node, NmtState state, TimeUs now) {
  SensorApplication::on_nmt_state(node, state, now);
  const bool indication = (node.values().u(0x1F80, 0) & 0x02) != 0;
  state_.indication_due =
      state == NmtState::kOperational && indication ? now + settings_.start_indication_delay : kNever;
  node.wake_app(now);
}

// ---- the vendor objects (cmp.hpp: kObjectHooks); the others are the chain's

using Cmp = CmpApplication;
constexpr ObjectHook<Cmp> CmpApplication::kObjectRows[] = {
    object<Cmp>(kBaudRate, nullptr, &Cmp::check_baud_rate, &Cmp::written_baud_rate),
    object<Cmp>(kMappingMode, nullptr, &Cmp::check_mapping_mode, &Cmp::written_mapping_mode),
    object<Cmp>(kLastNodeError, &Cmp::read_last_node_error),
    object<Cmp>(kMsCounter, &Cmp::read_ms_counter),
    area<Cmp>(kActualMessage, kActualMessage + 1, &Cmp::read_actual_message),
};
constexpr ObjectHooks<Cmp> CmpApplication::kObjectHooks{kObjectRows};

void CmpApplication::read_ms_counter(Node& node, const OdEntry& e, TimeUs now) {
  node.values().set_u(e, std::uint64_t(now / 1000) & 0xFF);
}

// P 0x2245, T 0x2246.
void CmpApplication::read_actual_message(Node& node, const OdEntry& e, TimeUs) {
  render_special_message(node, e, e.index - kActualMessage);
}

void CmpApplication::read_last_node_error(Node& node, const OdEntry& e, TimeUs) {
  const std::uint64_t newest = node.emcy().active_count() ? node.values().u(0x1003, 1) & 0xFFFF : 0;
  node.values().set_u(e, newest);
}

SdoAbort CmpApplication::check_mapping_mode(Node&, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  const std::uint64_t mode = decode_u(e.type, data.data());
  return mode <= kMaxMode && settings_.modes[mode].defined ? SdoAbort::kNone : SdoAbort::kInvalidValue;
}

SdoAbort CmpApplication::check_baud_rate(Node&, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  return bit_rate_index(decode_u(e.type, data.data())) < 0 ? SdoAbort::kInvalidValue : SdoAbort::kNone;
}

void CmpApplication::written_mapping_mode(Node& node, const OdEntry& e, TimeUs now) {
  apply_mapping_mode(node, e.sub, true, now);
}

// Active after the next reset (like the LSS bit rate): apply_baud_rate.
void CmpApplication::written_baud_rate(Node&, const OdEntry&, TimeUs) {}

TimeUs CmpApplication::process(Node& node, TimeUs now) {
  auto route = [&](std::size_t ch, unsigned events) { route_events(node, ch, events, now); };
  TimeUs next = chain_.process(node, now, route);
  check_faults(node, now);
  if (state_.indication_due <= now) {
    state_.indication_due = kNever;
    node.send(CanFrame::make(cob::kNmt, {kNmtStart, settings_.start_indication_node_id}));
  }
  // The EMCY engine wakes the application when the error state changes;
  // an over-temperature fault starts or ends at an edge of the schedule.
  const physics::FaultSet* faults = chain_.fault_set();
  const TimeUs fault_edge = faults ? std::max(faults->next_edge_time(), now + 1) : kNever;
  next = std::min({next, repeat_beyond_limits(node, now), state_.indication_due, fault_edge});
  return next;
}

// Delta and threshold events go to the PDOs whose EventMask selects them,
// for transmission types 0 and 254 only (manual, "Event Mask").
void CmpApplication::route_events(Node& node, std::size_t ch, unsigned events, TimeUs now) {
  const physics::Channel kind = chain_.profile().channels[ch].source;
  std::uint8_t bits = 0;
  if (events & kEventDelta) bits |= delta_bit(kind);
  if (events & (kEventUpperUp | kEventUpperDown)) bits |= upper_bit(kind);
  if (events & (kEventLowerDown | kEventLowerUp)) bits |= lower_bit(kind);
  if (events & kEventUpperUp) state_.limit_state[ch] = kUpperLimitUp;
  if (events & kEventUpperDown) state_.limit_state[ch] = kUpperLimitDown;
  if (events & kEventLowerDown) state_.limit_state[ch] = kLowerLimitDown;
  if (events & kEventLowerUp) state_.limit_state[ch] = kLowerLimitUp;
  node.values().set_u(kLimitEventType, std::uint8_t(ch + 1), state_.limit_state[ch]);
  if (!bits) return;
  for (unsigned n = 1; n <= kPdoCount; ++n) {
    const Tpdo* t = node.pdo().tpdo(n);
    if (t && (t->cfg.type == 0 || t->cfg.type == 254) && (node.values().u(kEventMask, std::uint8_t(n)) & bits)) {
      node.pdo().raise_event(n, now);
      state_.repeat_due[n - 1] = kNever;  // the timer counts from this transmission
    }
  }
}

// 0x2001 (kbit/s, 0 = automatic): a saved value is the bit rate from the next
// power-on / reset node on; the object then shows the active rate.
void CmpApplication::apply_baud_rate(Node& node) {
  const OdEntry* e = node.od().find(kBaudRate, 0);
  if (!e) return;
  std::uint64_t stored = 0;
  if (node.store().stored_u(*e, stored) && bit_rate_index(stored) >= 0)
    node.set_bit_rate_index(std::uint8_t(bit_rate_index(stored)));
  const std::uint8_t active = node.bit_rate_index();
  node.values().set_u(*e, active < 10 ? kBitRatesKbit[active] : 0);
}

// Mirrors the PDO's mapping mode into 0x1A0x; a new mode also resets the
// EventMask to the table's standard value (manual, "Event Mask": Important).
void CmpApplication::apply_mapping_mode(Node& node, unsigned n, bool reset_mask, TimeUs now) {
  const auto mode = unsigned(node.values().u(kMappingMode, std::uint8_t(n)));
  const MappingMode& m = settings_.modes[std::min(mode, kMaxMode)];
  const auto map = std::uint16_t(0x1A00 + n - 1);
  node.values().set_u(map, 0, m.count);
  for (unsigned i = 0; i < kMaxEntries; ++i)
    node.values().set_u(map, std::uint8_t(i + 1), i < m.count ? m.entries[i] : 0);
  if (reset_mask) node.values().set_u(kEventMask, std::uint8_t(n), m.event_mask);
  node.pdo().mapping_changed(n, now);
}

void CmpApplication::render_special_message(Node& node, const OdEntry& e, unsigned ch) {
  std::uint8_t bytes[8] = {};
  if (ch < state_.limit_state.size() && state_.limit_state[ch] != kNoLimitEvent) {
    const auto index = std::uint16_t(kSpecialMessages + 4 * ch + state_.limit_state[ch] - 1);
    if (const OdEntry* msg = node.od().find(index, 0)) {
      const auto v = node.values().bytes(*msg);
      std::memcpy(bytes, v.data(), std::min<std::size_t>(v.size(), sizeof bytes));
    }
  }
  node.values().set_bytes(e, bytes);
}

// Type 254 with an event timer: "a transmission only takes place in case the
// actual measured value passes above the upper threshold or below the lower
// threshold" (manual, Transmission Type; table footnote *).
TimeUs CmpApplication::repeat_beyond_limits(Node& node, TimeUs now) {
  if (!settings_.timer_repeats_beyond_limits || !node.allowed(Service::kPdo)) {
    state_.repeat_due.fill(kNever);
    return kNever;
  }
  TimeUs next = kNever;
  for (unsigned n = 1; n <= kPdoCount; ++n) {
    TimeUs& due = state_.repeat_due[n - 1];
    const Tpdo* t = node.pdo().tpdo(n);
    const TimeUs timer_ms = t ? t->cfg.event_ms : 0;
    if (!t || !node.pdo().valid(t->cfg) || t->cfg.type != 254 || !timer_ms ||
        !beyond_limits(node.values().u(kEventMask, std::uint8_t(n)))) {
      due = kNever;
      continue;
    }
    if (due == kNever) {
      due = now + ms(TimeUs(timer_ms));
    } else if (due <= now) {
      node.pdo().raise_event(n, now);
      due = now + ms(TimeUs(timer_ms));
    }
    next = std::min(next, due);
  }
  return next;
}

bool CmpApplication::beyond_limits(std::uint64_t mask) const {
  for (std::size_t ch = 0; ch < state_.limit_state.size() && ch < chain_.profile().channels.size(); ++ch) {
    const physics::Channel kind = chain_.profile().channels[ch].source;
    if ((mask & upper_bit(kind)) && state_.limit_state[ch] == kUpperLimitUp) return true;
    if ((mask & lower_bit(kind)) && state_.limit_state[ch] == kLowerLimitDown) return true;
  }
  return false;
}

// "The contents of the memory (EEProm) are checked at start-up."
void CmpApplication::self_test_at_start_up(Node& node, TimeUs now) {
  std::uint16_t sub = 0;
  if (DevicePart::boot_data_error(node, chain_.fault_set(), now)) sub = kSubUserPageChecksums;
  node.values().set_u(kNodeSubError, 0, sub);
  if (sub) raise(node, kEmcyDataSet, sub, now);
}

void CmpApplication::raise(Node& node, std::uint16_t code, std::uint16_t sub, TimeUs now) {
  std::uint8_t mfr[5] = {};
  mfr[kSubCodeOffset] = std::uint8_t(sub);
  mfr[kSubCodeOffset + 1] = std::uint8_t(sub >> 8);
  node.emcy().raise(code, 0, mfr, now);
}

// Permanent autotest: sensor temperature (over_temperature fault) and the
// bus (life guarding / heartbeat consumer, EMCY 0x8130 from the core). A
// fault forces PRE-OPERATIONAL; with Auto-Start the node returns to
// OPERATIONAL by itself once every fault is gone (AUTO-PRE-OPERATIONAL).
void CmpApplication::check_faults(Node& node, TimeUs now) {
  const bool hot = DevicePart::fault_active(chain_.fault_set(), physics::FaultKind::OverTemperature, now);
  node.emcy().follow(kEmcyDeviceTemperature, hot, 0, now);  // NodeSubErrorCode 0
  const bool fault = node.emcy().active_count() != 0;
  if (fault) {
    if (node.state() == NmtState::kOperational) node.nmt().command(kNmtEnterPreOperational, now);
    if (state_.auto_start && node.state() == NmtState::kPreOperational) state_.auto_resume = true;
  } else if (state_.auto_resume) {
    state_.auto_resume = false;
    if (node.state() == NmtState::kPreOperational) node.nmt().command(kNmtStart, now);
  }
}

}  // namespace cansim::personalities::cmp
