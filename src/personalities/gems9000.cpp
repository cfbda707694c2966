#include "personalities/gems9000.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "physics/fault.hpp"

namespace cansim::personalities::gems9000 {

namespace {

enum : std::uint16_t {
  kSeconds = 0x2005,
  kFilter = 0x2030,
  kPeakControl = 0x2031,
  kUserUnit = 0x2032,
  kPin = 0x20FF,
  kExperiencedFirst = 0x2800,
  kExperiencedLast = 0x2FFF,
  kOverflowControl = 0x2803,
  kBootLoad = 0x2810,
  kNetwork = 0x2813,
  kMaximum = 0x4130,
  kMinimum = 0x4131,
  kString = 0x5130,
  kFieldValue = 0x7100,
};

// Fig. 28: EMCY code and the error register the manual prints with it.
enum : std::uint16_t { kEmcySensor = 0x2201, kEmcyMaths = 0x6101, kEmcyNvm = 0x6102 };
constexpr std::uint8_t kRegSensor = 0xC0;
constexpr std::uint8_t kRegMaths = 0x81;

constexpr std::uint32_t kBootSignature = 0x746F6F62;  // "boot"
constexpr char kZero[4] = {'z', 'e', 'r', 'o'};

// Per channel (0 pressure, 1 temperature), §4.6.2.
constexpr std::uint16_t kOverflowCounter[2] = {0x2006, 0x2008};
constexpr std::uint16_t kUnderflowCounter[2] = {0x2007, 0x2009};
constexpr double kSpanHysteresis = 0.005;           // of the span, so noise at a limit counts once
constexpr std::uint16_t kReferenceCounts = 0x8000;  // 0x7100:03, mid-scale
constexpr std::uint64_t kCounterMax = 0xFFFF;       // UNSIGNED16 counters 0x2006-0x2009

double real_of(std::span<const std::uint8_t> data) {
  return data.size() >= 4 ? decode_f(DataType::kReal32, data.data()) : std::nan("");
}

// §4.2.3: left-justified, space padded, no terminator; decimals are dropped
// until the text fits the 8 bytes.
std::size_t format_value(double v, int digits, char (&out)[9]) {
  char text[48];
  int n = 0;
  for (int dd = digits; dd >= 0; --dd) {
    n = std::snprintf(text, sizeof text, "%.*f", dd, v);
    if (n > 0 && n <= 8) break;
  }
  n = std::clamp(n, 0, 8);
  std::memset(out, ' ', 8);
  std::memcpy(out, text, std::size_t(n));
  out[8] = '\0';
  return 8;
}

}  // namespace

void GemsApplication::on_reset(Node& node, ResetKind kind, TimeUs now) {
  SensorApplication::on_reset(node, kind, now);
  state_.sensor_failed[0] = state_.sensor_failed[1] = state_.math_error = false;  // the EMCY producer forgot them
  if (kind != ResetKind::kCommunication) {
    state_.unlocked = false;  // the PIN unlock lasts until reset node / power-off
    for (std::size_t ch = 0; ch < 2; ++ch) {
      state_.peaks_valid[ch] = false;
      state_.span[ch] = SpanMonitor{};
      if (ch < chain_.profile().channels.size()) apply_vendor_filter(node, ch);
    }
    if (kind == ResetKind::kPowerOn) state_.powered_at = now;
    if (DevicePart::boot_data_error(node, chain_.fault_set(), now))
      node.emcy().raise(kEmcyNvm, settings_.manual_error_register ? kRegMaths : 0, now);
  }
  // §3.2.1 / §4.6.3: 0x2813 = 0 enters OPERATIONAL "when excitation is
  // applied", without the boot-up message.
  const bool power_on_path = kind == ResetKind::kPowerOn || settings_.autostart_on_nmt_reset;
  if (power_on_path && node.values().u(kNetwork, 0) == 0) {
    BootPlan& plan = node.nmt().boot_plan();
    plan.send_boot_up = false;
    plan.self_start = true;
    plan.self_start_delay = 0;
  }
}

void GemsApplication::apply_vendor_filter(Node& node, std::size_t ch) {
  const ChannelConfig& c = chain_.profile().channels[ch];
  const OdEntry* e = node.od().find(kFilter, c.sub);
  if (!e) return;
  const double tau = node.values().get_f(*e);
  physics::FilterSpec f;
  if (tau > 0) {
    const double rate = 1e6 / double(chain_.source().sample_period_us(c.source));
    f = physics::FilterSpec::from_time(physics::FilterType::FirstOrder, tau, rate);
  }
  chain_.source().set_filter(c.source, f);
}

// ---- the vendor objects (gems9000.hpp: kObjectHooks); the others are the chain's

using Gems = GemsApplication;
constexpr ObjectHook<Gems> GemsApplication::kObjectRows[] = {
    object<Gems>(kSeconds, &Gems::read_seconds),
    object<Gems>(kFilter, nullptr, &Gems::check_filter, &Gems::written_filter),
    object<Gems>(kPeakControl, nullptr, nullptr, &Gems::written_peak_control),
    object<Gems>(kUserUnit, nullptr, &Gems::check_user_unit),
    object<Gems>(kPin, nullptr, &Gems::check_pin),
    area<Gems>(kExperiencedFirst, kExperiencedLast, nullptr, &Gems::check_experienced, &Gems::written_experienced),
    object<Gems>(kOverflowControl, nullptr, &Gems::check_overflow_control, &Gems::written_overflow_control),
    object<Gems>(kBootLoad, nullptr, &Gems::check_boot_load, &Gems::written_boot_load),
    object<Gems>(kNetwork, nullptr, nullptr, &Gems::written_network),
    object<Gems>(kMaximum, &Gems::read_peak),
    object<Gems>(kMinimum, &Gems::read_peak),
    object<Gems>(kString, &Gems::read_string),
    object<Gems>(kFieldValue, &Gems::read_field_value),
};
constexpr ObjectHooks<Gems> GemsApplication::kObjectHooks{kObjectRows};

std::size_t GemsApplication::channel_of(const OdEntry& e) const {
  return e.sub >= 1 && e.sub <= chain_.profile().channels.size() ? e.sub - 1u : 0u;
}

// ---- reads

void GemsApplication::read_seconds(Node& node, const OdEntry& e, TimeUs now) {
  node.values().set_u(e, std::uint64_t((now - state_.powered_at) / 1000000));
}

void GemsApplication::read_peak(Node& node, const OdEntry& e, TimeUs now) {
  const std::size_t ch = channel_of(e);
  track_peaks(node, ch, chain_.measure(node, ch, now).pv, false);
}

void GemsApplication::read_string(Node& node, const OdEntry& e, TimeUs now) {
  const std::size_t ch = e.sub - 1u;
  if (ch >= chain_.profile().channels.size()) return;
  char text[9];
  const std::size_t n = format_value(chain_.measure(node, ch, now).pv, chain_.digits(node, ch), text);
  node.values().set_string(e, std::string_view(text, n));
}

void GemsApplication::read_field_value(Node& node, const OdEntry& e, TimeUs) {
  node.values().set_u(e, kReferenceCounts);
}

// ---- write checks

SdoAbort GemsApplication::check_pin(Node&, const OdEntry&, std::span<const std::uint8_t> data, TimeUs) {
  state_.unlocked = data.size() >= 4 && decode_u(DataType::kUnsigned32, data.data()) == settings_.pin;
  return state_.unlocked ? SdoAbort::kNone : SdoAbort::kDataTransfer;
}

SdoAbort GemsApplication::check_filter(Node&, const OdEntry&, std::span<const std::uint8_t> data, TimeUs) {
  const double tau = real_of(data);
  return std::isfinite(tau) && tau >= 0 ? SdoAbort::kNone : SdoAbort::kInvalidValue;
}

SdoAbort GemsApplication::check_user_unit(Node&, const OdEntry&, std::span<const std::uint8_t> data, TimeUs) {
  const double m = real_of(data);
  return std::isfinite(m) && m > 0 ? SdoAbort::kNone : SdoAbort::kInvalidValue;
}

// §4.6.1: the experienced user area is writable after the PIN only; the
// abort code is not documented (spec §11 #24: 0x08000020).
SdoAbort GemsApplication::check_experienced(Node&, const OdEntry&, std::span<const std::uint8_t>, TimeUs) {
  return state_.unlocked ? SdoAbort::kNone : SdoAbort::kDataTransfer;
}

SdoAbort GemsApplication::check_overflow_control(Node& node, const OdEntry& e, std::span<const std::uint8_t> data,
                                                 TimeUs now) {
  if (SdoAbort a = check_experienced(node, e, data, now); !ok(a)) return a;
  return data.size() == 4 && std::memcmp(data.data(), kZero, 4) == 0 ? SdoAbort::kNone : SdoAbort::kDataTransfer;
}

SdoAbort GemsApplication::check_boot_load(Node& node, const OdEntry& e, std::span<const std::uint8_t> data,
                                          TimeUs now) {
  if (SdoAbort a = check_experienced(node, e, data, now); !ok(a)) return a;
  const bool boot = data.size() >= 4 && decode_u(DataType::kUnsigned32, data.data()) == kBootSignature;
  return boot ? SdoAbort::kNone : SdoAbort::kDataTransfer;
}

// ---- writes

void GemsApplication::written_filter(Node& node, const OdEntry& e, TimeUs) { apply_vendor_filter(node, channel_of(e)); }

void GemsApplication::written_peak_control(Node& node, const OdEntry& e, TimeUs now) {
  const std::size_t ch = channel_of(e);
  track_peaks(node, ch, chain_.measure(node, ch, now).pv, true);
}

// Fig. 38 writes the calibration dates after the last 'save': the area goes
// straight to NVM (spec §11 #20).
void GemsApplication::written_experienced(Node& node, const OdEntry& e, TimeUs now) {
  const OdEntry* one[] = {&e};
  if (settings_.direct_nvm && e.persist != kPersistNone && !node.store().save_entries(one))
    node.emcy().report(kEmcyNvm, settings_.manual_error_register ? kRegMaths : 0, nullptr, now);
}

// 'zero' clears the channel's span counters (§4.6.2).
void GemsApplication::written_overflow_control(Node& node, const OdEntry& e, TimeUs now) {
  if (const std::size_t ch = channel_of(e); ch < 2) {
    node.values().set_u(kOverflowCounter[ch], 0, 0);
    node.values().set_u(kUnderflowCounter[ch], 0, 0);
  }
  written_experienced(node, e, now);
}

void GemsApplication::written_boot_load(Node& node, const OdEntry& e, TimeUs now) {
  state_.boot_requested = true;
  written_experienced(node, e, now);
}

void GemsApplication::written_network(Node& node, const OdEntry& e, TimeUs now) {
  if (settings_.boot_alias_2813 && node.values().get_u(e) == 'b') state_.boot_requested = true;
  written_experienced(node, e, now);
}

// Max / min since reset node, power-on or the last 0x2031 write (spec §11 #26).
void GemsApplication::track_peaks(Node& node, std::size_t ch, double pv, bool restart) {
  if (ch >= 2 || !std::isfinite(pv)) return;
  const std::uint8_t sub = chain_.profile().channels[ch].sub;
  const OdEntry* max = node.od().find(kMaximum, sub);
  const OdEntry* min = node.od().find(kMinimum, sub);
  if (!max || !min) return;
  OdValues& v = node.values();
  const bool fresh = restart || !state_.peaks_valid[ch];
  if (fresh || pv > v.get_f(*max)) v.set_f(*max, pv);
  if (fresh || pv < v.get_f(*min)) v.set_f(*min, pv);
  state_.peaks_valid[ch] = true;
}

// §4.6.2: one count per excursion beyond span start / end.
void GemsApplication::count_span(Node& node, std::size_t ch, double pv) {
  if (ch >= 2) return;
  const double start = chain_.get(node, ch, Role::kSpanStart);
  const double end = chain_.get(node, ch, Role::kSpanEnd);
  SpanMonitor& span = state_.span[ch];
  if (!span.track(pv, start, end, kSpanHysteresis * std::fabs(end - start))) return;
  if (span.span == Span::kOver) saturating_count(node, node.od().find(kOverflowCounter[ch], 0), kCounterMax);
  if (span.span == Span::kUnder) saturating_count(node, node.od().find(kUnderflowCounter[ch], 0), kCounterMax);
}

void GemsApplication::supervise_channel(Node& node, std::size_t ch, TimeUs now) {
  const Cia404Chain::Measurement m = chain_.measure(node, ch, now);
  state_.sensor_failed[ch] = (m.status & physics::kStatusInvalid) != 0;
  if (!std::isfinite(m.pv)) {
    state_.math_error = true;
    return;
  }
  track_peaks(node, ch, m.pv, false);
  count_span(node, ch, m.pv);
}

TimeUs GemsApplication::process(Node& node, TimeUs now) {
  const TimeUs next = chain_.process(node, now);
  return std::min(next, device_.supervise(now, settings_.supervision_period_us, [&] { supervise(node, now); }));
}

void GemsApplication::supervise(Node& node, TimeUs now) {
  state_.math_error = false;
  const std::size_t channels = std::min<std::size_t>(2, chain_.profile().channels.size());
  for (std::size_t ch = 0; ch < channels; ++ch) supervise_channel(node, ch, now);
  const bool manual = settings_.manual_error_register;
  node.emcy().follow(kEmcySensor, state_.sensor_failed[0] || state_.sensor_failed[1], manual ? kRegSensor : 0, now);
  node.emcy().follow(kEmcyMaths, state_.math_error, manual ? kRegMaths : 0, now);
}

}  // namespace cansim::personalities::gems9000
