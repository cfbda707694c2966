#include "personalities/smc.hpp"

#include <stdexcept>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/cob_id.hpp"
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

bool is_field_or_process_value(std::uint16_t index) {
  return index == 0x6130 || index == 0x7100 || index == 0x7130 || index == 0x9130;
}

std::size_t channel_of(std::uint8_t sub) { return sub >= 2 ? 1 : 0; }

}  // namespace

void SmcApplication::MinMax::add(std::int32_t v) {
  if (!any) min = max = v;
  min = std::min(min, v);
  max = std::max(max, v);
  any = true;
}

SmcApplication::SmcApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                               const Settings& settings, std::uint32_t node_index)
    : chain_(std::move(profile), std::move(source)), device_(DevicePart::seed_of(node_index)), settings_(settings) {}

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

// ---------------------------------------------------------------- reads

void SmcApplication::refresh(Node& node, const OdEntry& e, TimeUs now) {
  load_chain(node);
  OdValues& v = node.values();
  switch (e.index) {
    case 0x1002: {  // §6.1.3: bits 15..8 = 0x6150:02, bits 7..0 = 0x6150:01
      std::uint32_t reg = 0;
      for (std::size_t ch = 0; ch < 2; ++ch)
        reg |= std::uint32_t(chain_.measure(node, ch, now).status | state_.latched_status[ch]) << (8 * ch);
      v.set_u(e, reg);
      return;
    }
    case 0x1008:
    case 0x4022:
      return refresh_device_name(node);
    case 0x3130:
    case 0x3131: {  // min / max FV, reported through the current offset, scaling and clamping
      if (e.sub == 0) return;
      const std::size_t ch = (e.sub - 1u) / 2;
      const MinMax& m = (e.index == 0x3130 ? state_.uptime : state_.lifetime)[ch];
      const std::int32_t fv = (e.sub - 1u) % 2 ? m.max : m.min;
      v.set_f(e, m.any ? state_.input[ch].scale(fv) : 0.0);
      return;
    }
    case 0x3140:
    case 0x3141: {  // internal millisecond clock from the boot (no TIME consumer yet)
      const TimeUs ms_total = (now - state_.boot_time) / 1000;
      v.set_u(e, e.index == 0x3140 ? std::uint64_t(ms_total / 86400000) : std::uint64_t(ms_total % 86400000));
      return;
    }
    case 0x3200: {
      const LinearInput& c = state_.input[channel_of(e.sub)];
      v.set_u(e, c.cmin != -kFltMax || c.cmax != kFltMax ? 1 : 0);
      return;
    }
    case 0x4001:
      v.set_u(e, node.node_id());
      return;
    case 0x4030:
      if (v.get_u(e) == 0) v.set_u(e, v.u(0x1018, 4));
      return;
    default:
      break;
  }
  chain_.refresh(node, e, now);
  if (e.index == 0x6150 && e.sub >= 1 && e.sub <= 2) v.set_u(e, v.get_u(e) | state_.latched_status[e.sub - 1]);
  swap_if_big_endian(node, e);
}

// §6.3.6: 0x4000 = 1 sends field and process values big-endian (SDO and TPDO).
void SmcApplication::swap_if_big_endian(Node& node, const OdEntry& e) {
  if (!is_field_or_process_value(e.index) || e.sub == 0 || node.values().u(0x4000, 0) != 1) return;
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
  for (std::uint8_t k = 1; k <= 60; ++k)
    node.values().set_u(0x4022, k, k <= factory.size() ? factory[k - 1] : 0);
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

// ---------------------------------------------------------------- writes

SdoAbort SmcApplication::check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  const std::uint64_t v = data.size() >= type_size(e.type) ? decode_u(e.type, data.data()) : 0;
  switch (e.index) {
    case 0x1012:  // a TIME consumer or producer, never both
      return (v & 0xC0000000u) == 0xC0000000u ? SdoAbort::kInvalidValue : SdoAbort::kNone;
    case 0x3126: {  // §6.3.1 fn 10: autozero only within +-10 % (2000 counts) of zero
      if (v != kZero) return SdoAbort::kDataTransfer;
      const std::int32_t fv = chain_.measure(node, channel_of(e.sub), now).raw;
      return std::abs(fv) <= 2000 ? SdoAbort::kNone : SdoAbort::kDataTransfer;
    }
    case 0x3130:
    case 0x3131:
      return e.sub == 0 && v == kRset ? SdoAbort::kNone : SdoAbort::kDataTransfer;
    case 0x3200:  // §6.3.4: writing 0 disables; enabling is done by writing min / max
      return v == 0 ? SdoAbort::kNone : SdoAbort::kInvalidValue;
    case 0x4001:
      return v >= 1 && v <= 127 ? SdoAbort::kNone : SdoAbort::kInvalidValue;
    case 0x4010:
      return v == 1 && node.values().u(0x4010, 1) == 0 ? SdoAbort::kInvalidValue : SdoAbort::kNone;
    case 0x4022:
      if (node.values().u(0x4022, 1) == 0) fill_device_name_chars(node);
      return SdoAbort::kNone;
    default:
      return chain_.check_write(node, e, data, now);
  }
}

void SmcApplication::after_write(Node& node, const OdEntry& e, TimeUs now) {
  OdValues& v = node.values();
  const std::size_t ch = channel_of(e.sub);
  switch (e.index) {
    case 0x3124:  // one input-offset register, two views
      v.set_f(*state_.objects[channel_of(e.sub)].input_offset, double(v.get_i(e)));
      break;
    case 0x3125:
      v.set_i(*state_.objects[channel_of(e.sub)].input_offset_i16, physics::to_decimal_i16(v.get_f(e), 0).value);
      break;
    case 0x3126: {  // "recent Field Value copied into the Input Offset register"
      chain_.invalidate();
      const std::int32_t fv = chain_.measure(node, ch, now).raw;
      v.set_f(*state_.objects[channel_of(e.sub)].input_offset, fv);
      v.set_i(*state_.objects[channel_of(e.sub)].input_offset_i16, fv);
      break;
    }
    case 0x3130:
    case 0x3131:
      for (MinMax& m : e.index == 0x3130 ? state_.uptime : state_.lifetime) m = MinMax{};
      v.set_u(e, 4);
      break;
    case 0x3200:  // "least and largest possible float32 values" to min / max
      v.set_f(*state_.objects[channel_of(e.sub)].clamp_min, -kFltMax);
      v.set_f(*state_.objects[channel_of(e.sub)].clamp_max, kFltMax);
      break;
    case 0x4001:
      return change_node_id(node, e.sub, std::uint8_t(v.get_u(e)), now);
    case 0x4022:
      refresh_device_name(node);
      break;
    case 0x4030:  // §6.3.12: writing the low part clears the high part; low = 0x1018:04 = LSS serial
      if (e.sub == 1) {
        v.set_u(0x4030, 2, 0);
        v.set_u(0x1018, 4, v.get_u(e));
      }
      break;
    case 0x4031:
      if (e.sub == 1) v.set_u(0x4031, 2, 0);
      break;
    case 0x6121:
    case 0x6123:
    case 0x6126:
    case 0x6127:
    case 0x9121:
    case 0x9123:
      after_scaling_write(node, e);
      break;
    default:
      chain_.after_write(node, e, now);
      if (e.index == 0x6132) write_scaling(node, ch, float(v.get_f(*state_.objects[channel_of(e.sub)].pv1)),
                                           float(v.get_f(*state_.objects[channel_of(e.sub)].pv2)));
      break;
  }
  load_chain(node);
}

// §6.2.6: PV1 / PV2 are the state; "always write the Offset value at first":
// an offset write moves PV1, a gain write moves PV2 using the current offset.
void SmcApplication::after_scaling_write(Node& node, const OdEntry& e) {
  OdValues& v = node.values();
  const std::uint8_t sub = e.sub;
  const std::size_t ch = channel_of(sub);
  float pv1 = float(v.get_f(*state_.objects[channel_of(sub)].pv1));
  float pv2 = float(v.get_f(*state_.objects[channel_of(sub)].pv2));
  const double pow10 = std::pow(10.0, double(std::min<std::uint64_t>(v.u(0x6132, sub), 9)));
  switch (e.index) {
    case 0x9121: pv1 = float(double(v.get_i(e)) / pow10); break;
    case 0x9123: pv2 = float(double(v.get_i(e)) / pow10); break;
    case 0x6127: pv1 = float(v.get_f(e)); break;
    case 0x6126: {
      const float gain = float(v.get_f(e));
      pv2 = float(v.get_f(*state_.objects[channel_of(sub)].scale_offset)) + gain * float(kFieldSpan);
      write_scaling(node, ch, pv1, pv2);
      v.set_f(e, gain);  // reads back exactly as written
      return;
    }
    default: break;
  }
  write_scaling(node, ch, pv1, pv2);
}

void SmcApplication::write_scaling(Node& node, std::size_t ch, float pv1, float pv2) {
  OdValues& v = node.values();
  const auto sub = std::uint8_t(ch + 1);
  const int dd = int(std::min<std::uint64_t>(v.u(0x6132, sub), 9));
  v.set_f(*state_.objects[channel_of(sub)].pv1, pv1);
  v.set_f(*state_.objects[channel_of(sub)].pv2, pv2);
  v.set_i(*state_.objects[channel_of(sub)].pv1_i32, physics::to_decimal_i32(pv1, dd).value);
  v.set_i(*state_.objects[channel_of(sub)].pv2_i32, physics::to_decimal_i32(pv2, dd).value);
  v.set_f(*state_.objects[channel_of(sub)].gain, (pv2 - pv1) / float(kFieldSpan));
  v.set_f(*state_.objects[channel_of(sub)].scale_offset, pv1);
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

// ---------------------------------------------------------------- registry


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

std::unique_ptr<Application> make(const model::Profile& profile, const Settings& settings, const NodeContext& ctx) {
  return std::make_unique<SmcApplication>(profile.cia404, make_sensor_source(profile, ctx), settings, ctx.index);
}

}  // namespace cansim::personalities::smc
