#include "config/vendor_settings.hpp"

#include <variant>

#include "core/pdo.hpp"

namespace cansim::config {

namespace {

using model::CmpSettings;

void parse(const VendorParams&, model::GenericSettings&, const model::Profile&) {}

void parse(const VendorParams& v, model::DpsSettings& s, const model::Profile&) {
  v.flags({{"span_overflow_emcy", &s.span_overflow_emcy}, {"autozero_shifts_span", &s.autozero_shifts_span}});
  v.time_us("span_check_period", s.span_check_period_us, VendorParams::kPositive, VendorParams::kForever, "a time > 0");
}

void parse(const VendorParams& v, model::P92cSettings& s, const model::Profile&) {
  v.integer("serial_part1", s.serial_part1, 0, 99);
  v.integer("serial_part3", s.serial_part3, 0, 9999);
  v.flags({{"overload_counters", &s.overload_counters},
           {"sensor_fault_emcy", &s.sensor_fault_emcy},
           {"overload_emcy", &s.overload_emcy},
           {"boot_emcys", &s.boot_emcys}});
  v.time_us("monitor_period", s.monitor_period_us, 1e-3, 10.0, "1 ms .. 10 s");
}

void parse(const VendorParams& v, model::GemsSettings& s, const model::Profile&) {
  v.integer("pin", s.pin, 0, 0xFFFFFFFF);
  v.flags({{"experienced_area_direct_nvm", &s.direct_nvm},
           {"autostart_on_nmt_reset", &s.autostart_on_nmt_reset},
           {"boot_alias_2813", &s.boot_alias_2813}});
  v.choice("emcy_register_mode", s.manual_error_register, "manual", "cia301");
  v.time_us("supervision_period", s.supervision_period_us, 1e-3, 10.0, "1 ms .. 10 s");
}

void parse(const VendorParams& v, model::SmcSettings& s, const model::Profile& p) {
  const physics::SensorSpec& sensor = p.physics.sensor;
  s.range_min[0] = sensor.pressure.range_min;
  s.range_max[0] = sensor.pressure.range_max;
  s.range_min[1] = sensor.temperature.range_min;
  s.range_max[1] = sensor.temperature.range_max;
  v.integer("ad_fault_info", s.ad_fault_info, 0, 0xFFFF);
  v.flags({{"reset_node_clears_error_register", &s.reset_node_clears_error_register},
           {"analog_error_reaction", &s.analog_error_reaction}});
  v.time_us("stay_set_period", s.stay_set_period_us, 1e-3, 1.0, "1 ms .. 1 s");
}

// A TPDO mapping entry the core would accept on a mapping write.
void check_mapping_entry(const Where& w, const YAML::Node& n, const OdLayout& layout, std::uint32_t raw,
                         unsigned& bits) {
  const PdoMapEntry m = PdoMapEntry::decode(raw);
  const OdEntry* e = layout.find(m.index, m.sub);
  if (!e || !e->pdo_mappable) fail(w, n, "expected a PDO-mappable object of this profile");
  if (!ok(check_pdo_map_entry(layout, raw, true, false)))
    fail(w, n, "the length in bits does not fit the object's type");
  bits += m.bits;
}

CmpSettings::MappingMode parse_mapping_mode(const Where& w, const YAML::Node& m, const OdLayout& layout) {
  check_keys(w, m, {"entries", "event_mask"});
  CmpSettings::MappingMode mode;
  mode.defined = true;
  const YAML::Node& list = m["entries"];
  if (!list || !list.IsSequence()) fail(w.child("entries"), m, "expected a list of mapping entries");
  if (list.size() > CmpSettings::kMaxEntries) fail(w.child("entries"), list, "at most 4 entries (0x1A0x subs 1..4)");
  unsigned bits = 0;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const auto raw = std::uint32_t(get_int(w.child("entries").item(i), list[i], 1, 0xFFFFFFFF));
    check_mapping_entry(w.child("entries").item(i), list[i], layout, raw, bits);
    mode.entries[mode.count++] = raw;
  }
  if (bits > 64) fail(w.child("entries"), list, "more than 8 bytes");
  if (m["event_mask"]) mode.event_mask = std::uint8_t(get_int(w.child("event_mask"), m["event_mask"], 0, 0x3F));
  return mode;
}

void parse(const VendorParams& v, CmpSettings& s, const model::Profile& p) {
  if (v.has("mapping_modes")) {
    const YAML::Node modes = v.node("mapping_modes");
    const Where wm = v.where("mapping_modes");
    if (!modes.IsMap()) fail(wm, modes, "expected a mapping of mode numbers to {entries, event_mask}");
    for (const auto& kv : modes) {
      const auto mode = unsigned(get_int(wm, kv.first, 1, CmpSettings::kMaxMode));
      s.modes[mode] = parse_mapping_mode(wm.child(kv.first.Scalar()), kv.second, *p.layout);
    }
  }
  v.time_us("start_indication_delay", s.start_indication_delay, 0.0, VendorParams::kForever, "a time >= 0");
  v.integer("start_indication_node_id", s.start_indication_node_id, 0, 127);
  s.timer_repeats_beyond_limits = !p.options->tpdo_event_timer_types.has(254);
}

void parse(const VendorParams& v, model::AnalogOutputSettings& s, const model::Profile& p) {
  unsigned channels = 0;
  while (channels < model::AnalogOutputSettings::kMaxChannels && p.layout->find(0x6411, std::uint8_t(channels + 1)) &&
         p.layout->find(0x6401, std::uint8_t(channels + 1)))
    ++channels;
  s.channels = channels;
  v.time_us("response_time", s.response_time_us, 1e-3, 3600.0, "1 ms .. 1 h");
}

}  // namespace

model::IdentitySettings parse_identity(const VendorParams& v) {
  model::IdentitySettings id;
  id.serial_per_node = v.integer("serial_number_base", id.serial_base, 0, 0xFFFFFFFF);
  return id;
}

void parse_device_settings(const VendorParams& v, model::Profile& profile) {
  std::visit([&](auto& settings) { parse(v, settings, profile); }, profile.device);
  v.reject_unknown_keys();
}

}  // namespace cansim::config
