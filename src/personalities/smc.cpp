#include "personalities/smc.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/protocol.hpp"
#include "core/nmt.hpp"
#include "physics/quantize.hpp"

namespace cansim::personalities::smc {

namespace {

// Magic signatures, wire order "zero" / "rset" (§11.1 of the spec, manual fn 11, 12).
constexpr std::uint32_t kZero = 0x6F72657A;
constexpr std::uint32_t kRset = 0x74657372;
constexpr std::uint16_t kEmcySensor = 0x5030;  // §4.8
constexpr std::uint8_t kInvalidBit = 0x01;     // 0x6150 bit 0 / 0x1001 bit 0
constexpr float kFltMax = std::numeric_limits<float>::max();
constexpr std::uint32_t kKeepBits = cob::kInvalid | cob::kNoRtr;  // 0x4001:02 keeps COB-ID bits 31, 30 (§6.3.7)
constexpr std::uint16_t kMinMaxSinceBoot = 0x3130;                // 0x3131: over the lifetime
constexpr std::uint16_t kClockDays = 0x3140;                      // 0x3141: ms of the day

std::size_t channel_of(std::uint8_t sub) { return sub >= 2 ? 1 : 0; }

}  // namespace

void SmcApplication::MinMax::add(std::int32_t v) {
  if (!any) min = max = v;
  min = std::min(min, v);
  max = std::max(max, v);
  any = true;
}

// ---------------------------------------------------------------- measurement chain (§5)

// The §5 chain of both channels from its objects, into the CiA 404 chain:
// the FV of the filtered sensor value, then the input offset, the scaling
// and the clamp (figure 1 of §5 is missing; order per spec §3), and the limit
// hysteresis of §6.2.9: "1 % of the total measuring span" (|PV2 - PV1|).
void SmcApplication::load_chain(const Node& node) {
  const OdValues& v = node.values();
  for (std::uint8_t sub = 1; sub <= 2; ++sub) {
    const ScalingObjects& o = state_.objects[channel_of(sub)];
    LinearInput& c = state_.input[sub - 1];
    c.si_min = settings_.range_min[sub - 1];
    c.si_max = settings_.range_max[sub - 1];
    c.field_span = kFieldSpan;
    c.gain = float(v.get_f(*o.gain));
    c.pv1 = float(v.get_f(*o.scale_offset));
    c.offset = float(v.get_f(*o.input_offset));
    c.cmin = float(v.get_f(*o.clamp_min));
    c.cmax = float(v.get_f(*o.clamp_max));
    if (!(c.cmin <= c.cmax)) c.cmax = c.cmin;
  }
  for (std::size_t ch = 0; ch < chain_.profile().channels.size(); ++ch) {
    const ScalingObjects& o = state_.objects[channel_of(std::uint8_t(ch + 1))];
    chain_.set_linear_input(ch, state_.input[channel_of(chain_.profile().channels[ch].sub)]);
    chain_.set_limit_hysteresis(ch, 0.01 * std::fabs(v.get_f(*o.pv2) - v.get_f(*o.pv1)));
  }
}

// ---------------------------------------------------------------- reset

// The scaling objects of both channels, which requirements() declares: the
// loader rejected a profile without them.
void SmcApplication::resolve_objects(const OdLayout& od) {
  auto need = [&](std::uint16_t index, std::uint8_t sub) -> const OdEntry* {
    const OdEntry* e = od.find(index, sub);
    if (!e) throw std::logic_error("adz-smc: a profile without a required object was not rejected by its loader");
    return e;
  };
  for (std::uint8_t sub = 1; sub <= 2; ++sub) {
    ScalingObjects& o = state_.objects[sub - 1];
    o = {need(0x6121, sub), need(0x6123, sub), need(0x9121, sub), need(0x9123, sub), need(0x6126, sub),
         need(0x6127, sub), need(0x3124, sub), need(0x3125, sub), need(0x3201, sub), need(0x3202, sub)};
  }
}

void SmcApplication::on_reset(Node& node, ResetKind kind, TimeUs now) {
  if (!state_.objects[0].pv1) resolve_objects(node.od());  // the layout is the node's for life
  SensorApplication::on_reset(node, kind, now);
  OdValues& v = node.values();
  const auto factory_serial = std::uint32_t(v.u(0x1018, 4));
  if (v.u(0x4030, 1) == 0) v.set_u(0x4030, 1, factory_serial);
  v.set_u(0x1018, 4, v.u(0x4030, 1));
  if (kind != ResetKind::kCommunication) {
    state_.boot_time = now;
    state_.uptime[0] = state_.uptime[1] = MinMax{};
  }
  if (kind == ResetKind::kPowerOn || (kind == ResetKind::kNode && settings_.reset_node_clears_error_register)) {
    state_.latched_error = false;
    state_.latched_status[0] = state_.latched_status[1] = 0;
  } else if (state_.latched_error) {
    node.emcy().restore_active(kEmcySensor, kInvalidBit);  // §6.1.2: until power-off
  }
  refresh_device_name(node);
  load_chain(node);
}

// ---------------------------------------------------------------- the vendor objects

// Every object the SMC serves itself (smc.hpp: kObjectHooks); the others are
// the CiA 404 chain's.
using Hook = ObjectHook<SmcApplication>;
constexpr Hook SmcApplication::kObjectRows[] = {
    object<SmcApplication>(0x1002, &SmcApplication::read_status_register),
    object<SmcApplication>(0x1008, &SmcApplication::read_device_name),
    object<SmcApplication>(0x1012, nullptr, &SmcApplication::check_time_cob_id),
    object<SmcApplication>(0x3124, nullptr, nullptr, &SmcApplication::written_input_offset_i16),
    object<SmcApplication>(0x3125, nullptr, nullptr, &SmcApplication::written_input_offset),
    object<SmcApplication>(0x3126, nullptr, &SmcApplication::check_autozero, &SmcApplication::written_autozero),
    area<SmcApplication>(0x3130, 0x3131, &SmcApplication::read_min_max, &SmcApplication::check_min_max_reset,
                         &SmcApplication::written_min_max_reset),
    area<SmcApplication>(0x3140, 0x3141, &SmcApplication::read_clock),
    object<SmcApplication>(0x3200, &SmcApplication::read_clamp_switch, &SmcApplication::check_clamp_switch,
                           &SmcApplication::written_clamp_switch),
    object<SmcApplication>(0x4001, &SmcApplication::read_node_id, &SmcApplication::check_node_id,
                           &SmcApplication::written_node_id),
    object<SmcApplication>(0x4010, nullptr, &SmcApplication::check_termination),
    object<SmcApplication>(0x4022, &SmcApplication::read_device_name, &SmcApplication::check_device_name,
                           &SmcApplication::written_device_name),
    object<SmcApplication>(0x4030, &SmcApplication::read_serial, nullptr, &SmcApplication::written_serial),
    object<SmcApplication>(0x4031, nullptr, nullptr, &SmcApplication::written_maintenance_time),
    object<SmcApplication>(0x6121, nullptr, nullptr, &SmcApplication::written_pv1_or_pv2),
    object<SmcApplication>(0x6123, nullptr, nullptr, &SmcApplication::written_pv1_or_pv2),
    object<SmcApplication>(0x6126, nullptr, nullptr, &SmcApplication::written_gain),
    object<SmcApplication>(0x6127, nullptr, nullptr, &SmcApplication::written_scale_offset),
    object<SmcApplication>(0x6130, &SmcApplication::read_in_byte_order),
    object<SmcApplication>(0x6132, nullptr, nullptr, &SmcApplication::written_digits),
    object<SmcApplication>(0x6150, &SmcApplication::read_status),
    object<SmcApplication>(0x7100, &SmcApplication::read_in_byte_order),
    object<SmcApplication>(0x7130, &SmcApplication::read_in_byte_order),
    object<SmcApplication>(0x9121, nullptr, nullptr, &SmcApplication::written_pv1_i32),
    object<SmcApplication>(0x9123, nullptr, nullptr, &SmcApplication::written_pv2_i32),
    object<SmcApplication>(0x9130, &SmcApplication::read_in_byte_order),
};
constexpr ObjectHooks<SmcApplication> SmcApplication::kObjectHooks{kObjectRows};

// The scaling objects may change outside a hooked write (a restore, the
// control API): the §5 chain is loaded again before every access.
void SmcApplication::refresh(Node& node, const OdEntry& e, TimeUs now) {
  load_chain(node);
  VendorApplication::refresh(node, e, now);
}

void SmcApplication::after_write(Node& node, const OdEntry& e, TimeUs now) {
  VendorApplication::after_write(node, e, now);
  load_chain(node);
}

// ---------------------------------------------------------------- reads

// §6.1.3: bits 15..8 = 0x6150:02, bits 7..0 = 0x6150:01.
void SmcApplication::read_status_register(Node& node, const OdEntry& e, TimeUs now) {
  std::uint32_t reg = 0;
  for (std::size_t ch = 0; ch < 2; ++ch)
    reg |= std::uint32_t(chain_.measure(node, ch, now).status | state_.latched_status[ch]) << (8 * ch);
  node.values().set_u(e, reg);
}

void SmcApplication::read_device_name(Node& node, const OdEntry&, TimeUs) { refresh_device_name(node); }

// Min / max FV (0x3130 since the boot, 0x3131 lifetime), reported through the
// current offset, scaling and clamping.
void SmcApplication::read_min_max(Node& node, const OdEntry& e, TimeUs) {
  if (e.sub == 0) return;
  const std::size_t ch = (e.sub - 1u) / 2;
  const MinMax& m = (e.index == kMinMaxSinceBoot ? state_.uptime : state_.lifetime)[ch];
  const std::int32_t fv = (e.sub - 1u) % 2 ? m.max : m.min;
  node.values().set_f(e, m.any ? state_.input[ch].scale(fv) : 0.0);
}

// The internal millisecond clock from the boot: 0x3140 days, 0x3141 ms of the
// day (no TIME consumer yet).
void SmcApplication::read_clock(Node& node, const OdEntry& e, TimeUs now) {
  const TimeUs ms_total = (now - state_.boot_time) / 1000;
  node.values().set_u(e,
                      e.index == kClockDays ? std::uint64_t(ms_total / 86400000) : std::uint64_t(ms_total % 86400000));
}

void SmcApplication::read_clamp_switch(Node& node, const OdEntry& e, TimeUs) {
  const LinearInput& c = state_.input[channel_of(e.sub)];
  node.values().set_u(e, c.cmin != -kFltMax || c.cmax != kFltMax ? 1 : 0);
}

void SmcApplication::read_node_id(Node& node, const OdEntry& e, TimeUs) { node.values().set_u(e, node.node_id()); }

void SmcApplication::read_serial(Node& node, const OdEntry& e, TimeUs) {
  if (node.values().get_u(e) == 0) node.values().set_u(e, node.values().u(0x1018, 4));
}

// 0x6150 bit 0 is held like 0x1001 (§6.1.2).
void SmcApplication::read_status(Node& node, const OdEntry& e, TimeUs now) {
  chain_.refresh(node, e, now);
  if (e.sub >= 1 && e.sub <= 2) node.values().set_u(e, node.values().get_u(e) | state_.latched_status[e.sub - 1]);
}

// §6.3.6: 0x4000 = 1 sends field and process values big-endian (SDO and TPDO).
void SmcApplication::read_in_byte_order(Node& node, const OdEntry& e, TimeUs now) {
  chain_.refresh(node, e, now);
  if (e.sub == 0 || node.values().u(0x4000, 0) != 1) return;
  const auto bytes = node.values().bytes(e);
  std::uint8_t swapped[8] = {};
  const std::size_t n = std::min<std::size_t>(bytes.size(), sizeof swapped);
  std::reverse_copy(bytes.begin(), bytes.begin() + std::ptrdiff_t(n), swapped);
  node.values().set_bytes(e, {swapped, n});
  chain_.live_objects_rewritten();
}

// §6.1.6 / §6.3.11: 0x1008 is the text of the character array 0x4022:1..60.
void SmcApplication::fill_device_name_chars(Node& node) {
  const OdEntry* name = node.od().find(0x1008, 0);
  if (!name) return;
  const auto& factory = name->default_bytes;
  for (std::uint8_t k = 1; k <= 60; ++k) node.values().set_u(0x4022, k, k <= factory.size() ? factory[k - 1] : 0);
}

void SmcApplication::refresh_device_name(Node& node) {
  if (node.values().u(0x4022, 1) == 0) fill_device_name_chars(node);
  const OdEntry* name = node.od().find(0x1008, 0);
  if (!name) return;
  char text[60];
  std::size_t n = 0;
  while (n < sizeof text) {
    const auto c = char(node.values().u(0x4022, std::uint8_t(n + 1)));
    if (c == 0) break;
    text[n++] = c;
  }
  node.values().set_string(*name, std::string_view(text, n));
}

// ---------------------------------------------------------------- write checks

namespace {
// The written value as an unsigned number (0 when shorter than the type).
std::uint64_t written_u(const OdEntry& e, std::span<const std::uint8_t> data) {
  return data.size() >= type_size(e.type) ? decode_u(e.type, data.data()) : 0;
}
SdoAbort valid_if(bool ok) { return ok ? SdoAbort::kNone : SdoAbort::kInvalidValue; }
}  // namespace

// A TIME consumer or producer, never both.
SdoAbort SmcApplication::check_time_cob_id(Node&, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  return valid_if((written_u(e, data) & 0xC0000000u) != 0xC0000000u);
}

// §6.3.1 fn 10: autozero only within +-10 % (2000 counts) of zero.
SdoAbort SmcApplication::check_autozero(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  if (written_u(e, data) != kZero) return SdoAbort::kDataTransfer;
  const std::int32_t fv = chain_.measure(node, channel_of(e.sub), now).raw;
  return std::abs(fv) <= 2000 ? SdoAbort::kNone : SdoAbort::kDataTransfer;
}

SdoAbort SmcApplication::check_min_max_reset(Node&, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  return e.sub == 0 && written_u(e, data) == kRset ? SdoAbort::kNone : SdoAbort::kDataTransfer;
}

// §6.3.4: writing 0 disables; enabling is done by writing min / max.
SdoAbort SmcApplication::check_clamp_switch(Node&, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  return valid_if(written_u(e, data) == 0);
}

SdoAbort SmcApplication::check_node_id(Node&, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  const std::uint64_t id = written_u(e, data);
  return valid_if(id >= 1 && id <= 127);
}

// The termination is enabled only where it is switchable (0x4010:01).
SdoAbort SmcApplication::check_termination(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  return valid_if(written_u(e, data) != 1 || node.values().u(0x4010, 1) != 0);
}

SdoAbort SmcApplication::check_device_name(Node& node, const OdEntry&, std::span<const std::uint8_t>, TimeUs) {
  if (node.values().u(0x4022, 1) == 0) fill_device_name_chars(node);
  return SdoAbort::kNone;
}

// ---------------------------------------------------------------- writes

// One input-offset register, two views (0x3124 INTEGER16, 0x3125 REAL32).
void SmcApplication::written_input_offset_i16(Node& node, const OdEntry& e, TimeUs) {
  node.values().set_f(*state_.objects[channel_of(e.sub)].input_offset, double(node.values().get_i(e)));
}

void SmcApplication::written_input_offset(Node& node, const OdEntry& e, TimeUs) {
  node.values().set_i(*state_.objects[channel_of(e.sub)].input_offset_i16,
                      physics::to_decimal_i16(node.values().get_f(e), 0).value);
}

// "recent Field Value copied into the Input Offset register".
void SmcApplication::written_autozero(Node& node, const OdEntry& e, TimeUs now) {
  chain_.invalidate();
  const ScalingObjects& o = state_.objects[channel_of(e.sub)];
  const std::int32_t fv = chain_.measure(node, channel_of(e.sub), now).raw;
  node.values().set_f(*o.input_offset, fv);
  node.values().set_i(*o.input_offset_i16, fv);
}

void SmcApplication::written_min_max_reset(Node& node, const OdEntry& e, TimeUs) {
  for (MinMax& m : e.index == kMinMaxSinceBoot ? state_.uptime : state_.lifetime) m = MinMax{};
  node.values().set_u(e, 4);
}

// "least and largest possible float32 values" to min / max.
void SmcApplication::written_clamp_switch(Node& node, const OdEntry& e, TimeUs) {
  node.values().set_f(*state_.objects[channel_of(e.sub)].clamp_min, -kFltMax);
  node.values().set_f(*state_.objects[channel_of(e.sub)].clamp_max, kFltMax);
}

void SmcApplication::written_node_id(Node& node, const OdEntry& e, TimeUs now) {
  change_node_id(node, e.sub, std::uint8_t(node.values().get_u(e)), now);
}

void SmcApplication::written_device_name(Node& node, const OdEntry&, TimeUs) { refresh_device_name(node); }

// §6.3.12: writing the low part clears the high part; low = 0x1018:04 = LSS serial.
void SmcApplication::written_serial(Node& node, const OdEntry& e, TimeUs) {
  if (e.sub != 1) return;
  node.values().set_u(0x4030, 2, 0);
  node.values().set_u(0x1018, 4, node.values().get_u(e));
}

void SmcApplication::written_maintenance_time(Node& node, const OdEntry& e, TimeUs) {
  if (e.sub == 1) node.values().set_u(0x4031, 2, 0);
}

// §6.2.6: PV1 / PV2 are the state; "always write the Offset value at first":
// an offset write moves PV1, a gain write moves PV2 using the current offset.
void SmcApplication::written_pv1_or_pv2(Node& node, const OdEntry& e, TimeUs) {
  const ScalingObjects& o = state_.objects[channel_of(e.sub)];
  write_scaling(node, channel_of(e.sub), float(node.values().get_f(*o.pv1)), float(node.values().get_f(*o.pv2)));
}

void SmcApplication::written_scale_offset(Node& node, const OdEntry& e, TimeUs) {
  const ScalingObjects& o = state_.objects[channel_of(e.sub)];
  write_scaling(node, channel_of(e.sub), float(node.values().get_f(e)), float(node.values().get_f(*o.pv2)));
}

void SmcApplication::written_gain(Node& node, const OdEntry& e, TimeUs) {
  OdValues& v = node.values();
  const ScalingObjects& o = state_.objects[channel_of(e.sub)];
  const float gain = float(v.get_f(e));
  const float pv2 = float(v.get_f(*o.scale_offset)) + gain * float(kFieldSpan);
  write_scaling(node, channel_of(e.sub), float(v.get_f(*o.pv1)), pv2);
  v.set_f(e, gain);  // reads back exactly as written
}

// The INTEGER32 views are PV1 / PV2 x 10^digits (0x6132).
void SmcApplication::written_pv1_i32(Node& node, const OdEntry& e, TimeUs) {
  const ScalingObjects& o = state_.objects[channel_of(e.sub)];
  write_scaling(node, channel_of(e.sub), float(double(node.values().get_i(e)) / pow10_digits(node, e.sub)),
                float(node.values().get_f(*o.pv2)));
}

void SmcApplication::written_pv2_i32(Node& node, const OdEntry& e, TimeUs) {
  const ScalingObjects& o = state_.objects[channel_of(e.sub)];
  write_scaling(node, channel_of(e.sub), float(node.values().get_f(*o.pv1)),
                float(double(node.values().get_i(e)) / pow10_digits(node, e.sub)));
}

// New digits re-render the integer views of PV1 / PV2.
void SmcApplication::written_digits(Node& node, const OdEntry& e, TimeUs now) {
  chain_.after_write(node, e, now);
  const ScalingObjects& o = state_.objects[channel_of(e.sub)];
  write_scaling(node, channel_of(e.sub), float(node.values().get_f(*o.pv1)), float(node.values().get_f(*o.pv2)));
}

double SmcApplication::pow10_digits(const Node& node, std::uint8_t sub) {
  return std::pow(10.0, double(std::min<std::uint64_t>(node.values().u(0x6132, sub), 9)));
}

void SmcApplication::write_scaling(Node& node, std::size_t ch, float pv1, float pv2) {
  OdValues& v = node.values();
  const auto sub = std::uint8_t(ch + 1);
  const int dd = int(std::min<std::uint64_t>(v.u(0x6132, sub), 9));
  const ScalingObjects& o = state_.objects[channel_of(sub)];
  v.set_f(*o.pv1, pv1);
  v.set_f(*o.pv2, pv2);
  v.set_i(*o.pv1_i32, physics::to_decimal_i32(pv1, dd).value);
  v.set_i(*o.pv2_i32, physics::to_decimal_i32(pv2, dd).value);
  v.set_f(*o.gain, (pv2 - pv1) / float(kFieldSpan));
  v.set_f(*o.scale_offset, pv1);
}

// §6.3.7 / §8.3: the new node-ID is applied at once, no SDO answer, a boot-up
// on the new ID; sub 2 also sets the pre-defined COB-IDs (bits 31, 30 kept).
void SmcApplication::change_node_id(Node& node, std::uint8_t sub, std::uint8_t id, TimeUs now) {
  if (sub == 2) {
    struct Cob {
      std::uint16_t index;
      std::uint8_t sub;
      std::uint32_t id;
    };
    for (Cob c : {Cob{0x1005, 0, cob::kSync}, Cob{0x1012, 0, cob::kTime}, Cob{0x1014, 0, cob::kEmcyBase + id},
                  Cob{0x1800, 1, cob::tpdo_default(1, id)}, Cob{0x1801, 1, cob::tpdo_default(2, id)}}) {
      const OdEntry* e = node.od().find(c.index, c.sub);
      if (e) node.values().set_u(*e, (node.values().get_u(*e) & kKeepBits) | c.id);
    }
  }
  node.set_node_id(id);
  node.nmt().reboot_keeping_values(now);
}

// ---------------------------------------------------------------- supervision

TimeUs SmcApplication::process(Node& node, TimeUs now) {
  load_chain(node);
  const TimeUs next = chain_.process(node, now);
  return std::min(next, device_.supervise(now, settings_.stay_set_period_us, [&] { supervise(node, now); }));
}

// Stay-set capture of the raw FV (before the input offset, §6.3.2) and the
// A/D fault detection, in every NMT state.
void SmcApplication::supervise(Node& node, TimeUs now) {
  for (std::size_t ch = 0; ch < 2 && ch < chain_.profile().channels.size(); ++ch) {
    const Cia404Chain::Measurement m = chain_.measure(node, ch, now);
    if (m.status & kInvalidBit) {
      if (!state_.latched_status[ch]) {
        state_.latched_status[ch] = kInvalidBit;
        sensor_error(node, now);
      }
      continue;
    }
    state_.uptime[ch].add(m.raw);
    state_.lifetime[ch].add(m.raw);
  }
}

// §4.8, §6.1.2, §6.1.17: EMCY 0x5030 + add-info, 0x1001 bit 0 latched, 0x1029:03.
void SmcApplication::sensor_error(Node& node, TimeUs now) {
  state_.latched_error = true;
  const std::uint8_t mfr[5] = {std::uint8_t(settings_.ad_fault_info), std::uint8_t(settings_.ad_fault_info >> 8)};
  node.emcy().raise(kEmcySensor, kInvalidBit, mfr, now);
  if (settings_.analog_error_reaction) node.nmt().error_reaction(3, now);
}

// §5: the measurement chain and its scaling objects, both channels.
constexpr RequiredObject kRequiredObjects[] = {{0x6121, 1, 2, "the input scaling (§5)"},
                                               {0x6123, 1, 2, "the input scaling (§5)"},
                                               {0x6126, 1, 2, "the scaling factor of its measurement chain (§5)"},
                                               {0x6127, 1, 2, "the scaling offset of its measurement chain (§5)"},
                                               {0x3124, 1, 2, "the offset of its measurement chain (§5)"},
                                               {0x3125, 1, 2, "the offset of its measurement chain (§5)"},
                                               {0x3201, 1, 2, "the output clamp of its measurement chain (§5)"},
                                               {0x3202, 1, 2, "the output clamp of its measurement chain (§5)"},
                                               {0x9121, 1, 2, "the integer input scaling (§5)"},
                                               {0x9123, 1, 2, "the integer input scaling (§5)"}};

Requirements requirements() { return {kRequiredObjects, 2, "its pressure and temperature chains (§5)"}; }

}  // namespace cansim::personalities::smc
