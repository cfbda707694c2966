#include "config/physics_config.hpp"

#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "config/limits.hpp"
#include "physics/table.hpp"
#include "physics/units.hpp"

namespace cansim::config {

namespace {

using namespace cansim::physics;

// ---------------------------------------------------------------- quantities

bool split_number(const std::string& s, double& number, std::string& unit) {
  const char* begin = s.c_str();
  char* end = nullptr;
  number = std::strtod(begin, &end);
  if (end == begin || !std::isfinite(number)) return false;
  std::string rest(end);
  std::size_t a = rest.find_first_not_of(' ');
  unit = a == std::string::npos ? "" : rest.substr(a);
  while (!unit.empty() && unit.back() == ' ') unit.pop_back();
  return true;
}

struct Scale {
  const char* name;
  double factor;
};
constexpr Scale kTimeUnits[] = {{"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}, {"µs", 1e-6}, {"min", 60.0}, {"h", 3600.0}};
constexpr Scale kFrequencyUnits[] = {{"Hz", 1.0}, {"kHz", 1e3}, {"rpm", 1.0 / 60.0}};

const char* expected_units(Dim dim) {
  switch (dim) {
    case Dim::kPressure: return "a pressure like '5 bar' (Pa, hPa, kPa, MPa, bar, mbar, psi, atm, at, mmHg)";
    case Dim::kTemperature: return "a temperature like '20 degC' (degC, degF, K)";
    case Dim::kTemperatureDelta: return "a temperature difference like '0.5 K' (K, degC, degF)";
    case Dim::kTime: return "a time like '10 ms' (s, ms, us, min, h)";
    case Dim::kFrequency: return "a frequency like '1 kHz' (Hz, kHz, rpm)";
    case Dim::kNumber: return "a number (or '<n> %')";
    case Dim::kMassFlow:
      return "a mass flow like '2 g/s' (kg/s, g/s, kg/min, g/min, kg/h, Nl/min, Nm3/h; l/min, m3/h of a liquid)";
    case Dim::kMass: return "a mass like '5 g' (kg, g)";
    case Dim::kPower: return "a power like '200 W' (W, kW, mW)";
    case Dim::kVolume: return "a volume like '2 l' (m3, l, dm3, ml, cm3)";
    case Dim::kArea: return "an area like '3 mm2' (m2, cm2, mm2)";
    case Dim::kLength: return "a length like '2 mm' (m, cm, mm)";
    case Dim::kDensity: return "a density like '870 kg/m3' (kg/m3, g/l)";
  }
  return "a quantity";
}

bool scaled(const Scale* table, std::size_t n, const std::string& unit, double v, double& out) {
  for (std::size_t i = 0; i < n; ++i) {
    if (unit == table[i].name) {
      out = v * table[i].factor;
      return true;
    }
  }
  return false;
}

QuantityKind plant_kind(Dim dim) {
  switch (dim) {
    case Dim::kMassFlow: return QuantityKind::kMassFlow;
    case Dim::kMass: return QuantityKind::kMass;
    case Dim::kPower: return QuantityKind::kPower;
    case Dim::kVolume: return QuantityKind::kVolume;
    case Dim::kArea: return QuantityKind::kArea;
    case Dim::kLength: return QuantityKind::kLength;
    default: return QuantityKind::kDensity;
  }
}

bool convert_quantity(double v, const std::string& unit, Dim dim, double& out, const Medium* medium = nullptr) {
  if (unit.empty()) {  // bare number: SI
    out = v;
    return true;
  }
  switch (dim) {
    case Dim::kPressure:
      if (auto u = parse_pressure_unit(unit)) return out = to_pa(v, *u), true;
      return false;
    case Dim::kTemperature:
      if (auto u = parse_temperature_unit(unit)) return out = to_kelvin(v, *u), true;
      return false;
    case Dim::kTemperatureDelta:
      if (auto u = parse_temperature_unit(unit)) return out = delta_to_kelvin(v, *u), true;
      return false;
    case Dim::kTime: return scaled(kTimeUnits, std::size(kTimeUnits), unit, v, out);
    case Dim::kFrequency: return scaled(kFrequencyUnits, std::size(kFrequencyUnits), unit, v, out);
    case Dim::kNumber:
      if (unit == "%") return out = v / 100.0, true;
      return false;
    default: {
      static const Medium kAir;
      const std::optional<Unit> u = find_unit(unit, medium ? *medium : kAir);
      if (!u || u->kind != plant_kind(dim)) return false;
      return out = from_unit(v, *u), true;
    }
  }
  return false;
}

// The dimensions of one process channel's values: absolute levels and
// differences (amplitudes, rates). Temperature levels of every term after
// the first are differences too: the terms add up (docs/profile-physics.md).
struct ChannelDims {
  Dim level;
  Dim delta;
  const Medium* medium = nullptr;
};

double q(const Where& w, const YAML::Node& map, const char* key, Dim dim, double def, const Medium* medium = nullptr) {
  return map[key] ? get_quantity(w.child(key), map[key], dim, medium) : def;
}
double num(const Where& w, const YAML::Node& map, const char* key, double def) {
  return q(w, map, key, Dim::kNumber, def);
}
void positive(const Where& w, const YAML::Node& n, double v, const char* what) {
  if (!(v > 0)) fail(w, n, std::string("expected ") + what + " > 0");
}

// ---------------------------------------------------------------- tables

TableSpec parse_table(const Where& w, const YAML::Node& m, Dim value_dim, const std::string& file) {
  check_keys(w, m, {"points", "csv", "time_unit", "value_unit", "interpolation", "loop", "period"});
  TableSpec t;
  if (m["points"]) {
    const YAML::Node& pts = m["points"];
    if (!pts.IsSequence() || pts.size() == 0) fail(w.child("points"), pts, "expected a list of [time, value] pairs");
    for (std::size_t i = 0; i < pts.size(); ++i) {
      Where wi = w.child("points").item(i);
      if (!pts[i].IsSequence() || pts[i].size() != 2) fail(wi, pts[i], "expected a [time, value] pair");
      t.points.push_back(
          {get_quantity(wi.item(0), pts[i][0], Dim::kTime), get_quantity(wi.item(1), pts[i][1], value_dim)});
    }
  } else if (m["csv"]) {
    std::string path = get_string(w.child("csv"), m["csv"]);
    if (!path.empty() && path[0] != '/') {
      auto slash = file.rfind('/');
      if (slash != std::string::npos) path = file.substr(0, slash + 1) + path;
    }
    double time_scale = 1.0, value_scale = 1.0, value_offset = 0.0;
    if (m["time_unit"]) {
      std::string u = get_string(w.child("time_unit"), m["time_unit"]);
      if (!scaled(kTimeUnits, std::size(kTimeUnits), u, 1.0, time_scale))
        fail(w.child("time_unit"), m["time_unit"], expected_units(Dim::kTime));
    }
    if (m["value_unit"]) {
      std::string u = get_string(w.child("value_unit"), m["value_unit"]);
      double one = 0, zero = 0;
      if (!convert_quantity(1.0, u, value_dim, one) || !convert_quantity(0.0, u, value_dim, zero))
        fail(w.child("value_unit"), m["value_unit"], expected_units(value_dim));
      value_scale = one - zero;
      value_offset = zero;
    }
    if (const std::vector<std::string>* folders = ConfinedFiles::current(); folders && !inside_any(path, *folders)) {
      std::string dirs;
      for (const auto& d : *folders) dirs += (dirs.empty() ? "" : ", ") + d;
      fail(w.child("csv"), m["csv"],
           "cannot load table: expected a file in the profile folders (" + (dirs.empty() ? std::string("none") : dirs) +
               ")");
    }
    std::string error, text;
    try {
      text = read_regular_file(path, limits::kTableFileBytes);
    } catch (const ConfigError& e) {
      fail(w.child("csv"), m["csv"], std::string("cannot load table: ") + e.what());
    }
    FilesRead::note(path, text);
    if (!parse_table_csv(text, t.points, &error, time_scale, value_scale, value_offset))
      fail(w.child("csv"), m["csv"], "cannot load table: " + path + ": " + error);
  } else {
    fail(w, m, "expected 'points' or 'csv'");
  }
  if (m["interpolation"]) {
    std::string s = get_string(w.child("interpolation"), m["interpolation"]);
    if (s == "linear") t.interpolation = Interpolation::Linear;
    else if (s == "hold") t.interpolation = Interpolation::Hold;
    else fail(w.child("interpolation"), m["interpolation"], "expected linear or hold");
  }
  if (m["loop"]) t.loop = get_bool(w.child("loop"), m["loop"]);
  t.period_s = q(w, m, "period", Dim::kTime, 0.0);
  for (std::size_t i = 1; i < t.points.size(); ++i)
    if (t.points[i].t_s < t.points[i - 1].t_s)
      fail(w.child("points").item(i), m["points"] ? m["points"][i] : m, "expected non-decreasing times");
  return t;
}

// A setpoint: a single level ("5 bar") or a table map.
TableSpec parse_setpoint(const Where& w, const YAML::Node& n, Dim dim, const std::string& file) {
  if (n.IsScalar()) return TableSpec{{{0.0, get_quantity(w, n, dim)}}, Interpolation::Hold, false, 0.0};
  return parse_table(w, n, dim, file);
}

// ---------------------------------------------------------------- terms

// What a term parser gets: the term's mapping and where it is.
struct TermArgs {
  const Where& w;
  const std::string& kind;
  const YAML::Node& m;
  const ChannelDims& d;
  bool pressure;
  const std::string& file;
  void need_map(std::initializer_list<const char*> keys) const {
    if (!m.IsMap()) fail(w, m, "expected a mapping of " + kind + " parameters");
    check_keys(w, m, keys);
  }
  double q(const char* key, Dim dim, double def) const { return config::q(w, m, key, dim, def, d.medium); }
  TableSpec setpoint() const {
    if (!m["setpoint"]) fail(w.child("setpoint"), m, "missing required key 'setpoint'");
    return parse_setpoint(w.child("setpoint"), m["setpoint"], d.level, file);
  }
};

TermSpec constant_term(const TermArgs& a) {
  if (a.m.IsScalar()) return ConstantSpec{get_quantity(a.w, a.m, a.d.level, a.d.medium)};
  a.need_map({"value"});
  return ConstantSpec{a.q("value", a.d.level, 0.0)};
}

TermSpec ramp_term(const TermArgs& a) {
  a.need_map({"from", "to", "start", "duration"});
  RampSpec r{a.q("from", a.d.level, 0.0), a.q("to", a.d.level, 0.0), a.q("start", Dim::kTime, 0.0),
             a.q("duration", Dim::kTime, 0.0)};
  if (r.duration_s < 0) fail(a.w.child("duration"), a.m["duration"], "expected a duration >= 0");
  return r;
}

TermSpec table_term(const TermArgs& a) { return TableTermSpec{parse_table(a.w, a.m, a.d.level, a.file)}; }

TermSpec sine_term(const TermArgs& a) {
  a.need_map({"amplitude", "frequency", "period", "phase"});
  SineSpec s;
  s.amplitude = a.q("amplitude", a.d.delta, 0.0);
  if (a.m["period"]) {
    double p = get_quantity(a.w.child("period"), a.m["period"], Dim::kTime);
    positive(a.w.child("period"), a.m["period"], p, "a period");
    s.frequency_hz = 1.0 / p;
  } else {
    s.frequency_hz = a.q("frequency", Dim::kFrequency, 1.0);
  }
  s.phase_rad = num(a.w, a.m, "phase", 0.0);
  return s;
}

TermSpec pulse_term(const TermArgs& a) {
  a.need_map({"low", "high", "period", "duty", "delay", "rise", "fall"});
  return PulseSpec{a.q("low", a.d.level, 0.0),  a.q("high", a.d.level, 0.0),   a.q("period", Dim::kTime, 1.0),
                   num(a.w, a.m, "duty", 0.5),  a.q("delay", Dim::kTime, 0.0), a.q("rise", Dim::kTime, 0.0),
                   a.q("fall", Dim::kTime, 0.0)};
}

TermSpec pulsation_term(const TermArgs& a) {
  const Where& w = a.w;
  const YAML::Node& m = a.m;
  a.need_map({"speed", "pistons", "amplitude", "harmonics"});
  double shaft_hz = a.q("speed", Dim::kFrequency, 25.0);
  if (m["harmonics"] && m["harmonics"].IsSequence()) {
    PulsationSpec p;
    p.shaft_hz = shaft_hz;
    const YAML::Node& hs = m["harmonics"];
    for (std::size_t i = 0; i < hs.size(); ++i) {
      Where wi = w.child("harmonics").item(i);
      check_keys(wi, hs[i], {"order", "amplitude", "phase"});
      p.harmonics.push_back(
          {num(wi, hs[i], "order", 1.0), q(wi, hs[i], "amplitude", a.d.delta, 0.0), num(wi, hs[i], "phase", 0.0)});
    }
    return p;
  }
  int pistons = m["pistons"] ? int(get_int(w.child("pistons"), m["pistons"], 1, 64)) : 1;
  int n = m["harmonics"] ? int(get_int(w.child("harmonics"), m["harmonics"], 1, 32)) : 3;
  return PulsationSpec::piston_pump(shaft_hz * 60.0, pistons, a.q("amplitude", a.d.delta, 0.0), n);
}

TermSpec first_order_term(const TermArgs& a) {
  a.need_map({"setpoint", "time_constant", "initial"});
  FirstOrderSpec f{a.setpoint(), a.q("time_constant", Dim::kTime, 1.0), a.q("initial", a.d.level, kNaN)};
  positive(a.w.child("time_constant"), a.m["time_constant"], f.time_constant_s, "a time constant");
  return f;
}

TermSpec second_order_term(const TermArgs& a) {
  a.need_map({"setpoint", "natural_frequency", "damping", "initial"});
  SecondOrderSpec s{a.setpoint(), a.q("natural_frequency", Dim::kFrequency, 1.0), num(a.w, a.m, "damping", 0.5),
                    a.q("initial", a.d.level, kNaN)};
  positive(a.w.child("natural_frequency"), a.m["natural_frequency"], s.natural_frequency_hz, "a frequency");
  positive(a.w.child("damping"), a.m["damping"], s.damping, "a damping ratio");
  return s;
}

TermSpec random_walk_term(const TermArgs& a) {
  a.need_map({"initial", "sigma", "drift", "min", "max"});
  RandomWalkSpec r;
  r.initial = a.q("initial", a.d.level, 0.0);
  r.sigma_per_sqrt_s = a.q("sigma", a.d.delta, 0.0);  // per sqrt(s)
  r.drift_per_s = a.q("drift", a.d.delta, 0.0);       // per s
  r.min = a.q("min", a.d.level, r.min);
  r.max = a.q("max", a.d.level, r.max);
  return r;
}

TermSpec ou_term(const TermArgs& a) {
  a.need_map({"mean", "sigma", "tau", "initial"});
  OrnsteinUhlenbeckSpec o{a.q("mean", a.d.level, 0.0), a.q("tau", Dim::kTime, 60.0), a.q("sigma", a.d.delta, 0.0),
                          a.q("initial", a.d.level, kNaN)};
  positive(a.w.child("tau"), a.m["tau"], o.tau_s, "a correlation time");
  return o;
}

TermSpec gas_law_term(const TermArgs& a) {
  if (!a.pressure) fail(a.w, a.m, "gas_law is a pressure term");
  a.need_map({"reference_pressure", "reference_temperature"});
  return GasLawSpec{a.q("reference_pressure", Dim::kPressure, 1.0e5),
                    a.q("reference_temperature", Dim::kTemperature, 293.15)};
}

// {plant: PLANT.VARIABLE}: the sensor reads a plant (docs/plants.md).
TermSpec plant_term(const TermArgs& a) {
  const std::string ref = get_string(a.w, a.m);
  const auto dot = ref.find('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == ref.size())
    fail(a.w, a.m, "expected PLANT.VARIABLE, e.g. vessel.pressure");
  return PlantTermSpec{ref, origin_of(a.w, a.m)};
}

TermSpec parse_term(const Where& w, const std::string& kind, const YAML::Node& m, const ChannelDims& d, bool pressure,
                    const std::string& file) {
  static const std::pair<const char*, TermSpec (*)(const TermArgs&)> kTerms[] = {{"plant", plant_term},
                                                                                 {"constant", constant_term},
                                                                                 {"ramp", ramp_term},
                                                                                 {"table", table_term},
                                                                                 {"sine", sine_term},
                                                                                 {"pulse", pulse_term},
                                                                                 {"pulsation", pulsation_term},
                                                                                 {"first_order", first_order_term},
                                                                                 {"second_order", second_order_term},
                                                                                 {"random_walk", random_walk_term},
                                                                                 {"ou", ou_term},
                                                                                 {"drift", ou_term},
                                                                                 {"gas_law", gas_law_term}};
  for (const auto& [name, parse] : kTerms)
    if (kind == name) return parse(TermArgs{w, kind, m, d, pressure, file});
  fail(w, m,
       "unknown process term '" + kind +
           "' (expected constant, ramp, table, sine, pulse, pulsation, first_order, second_order, "
           "random_walk, ou, gas_law, plant)");
}

YAML::Node sequence_of(const YAML::Node& item) {
  YAML::Node seq(YAML::NodeType::Sequence);
  seq.push_back(item);
  return seq;
}

// A term list (or one term, or a constant) of levels in `level`, later terms
// in `delta`. `pressure`: a pressure channel (gas_law is allowed).
void parse_term_list(const Where& w, const YAML::Node& n, const ChannelDims& dims, bool pressure,
                     std::vector<TermSpec>& out, const std::string& file) {
  out.clear();
  if (n.IsScalar()) {  // "5 bar": a constant
    out.push_back(ConstantSpec{get_quantity(w, n, dims.level, dims.medium)});
    return;
  }
  // Not assigned after construction: yaml-cpp's operator= would overwrite the aliased `n`.
  const YAML::Node list = n.IsMap() ? sequence_of(n) : n;  // a map: a single term
  if (!list.IsSequence() || list.size() == 0) fail(w, n, "expected a list of process terms");
  for (std::size_t i = 0; i < list.size(); ++i) {
    Where wi = n.IsMap() ? w : w.item(i);
    const YAML::Node& item = list[i];
    if (!item.IsMap() || item.size() != 1) fail(wi, item, "expected one term like '{constant: 5 bar}'");
    auto kv = *item.begin();
    std::string kind = kv.first.Scalar();
    ChannelDims d{out.empty() ? dims.level : dims.delta, dims.delta, dims.medium};
    out.push_back(parse_term(wi.child(kind), kind, kv.second, d, pressure, file));
  }
}

void parse_channel_terms(const Where& w, const YAML::Node& n, bool pressure, std::vector<TermSpec>& out,
                         const std::string& file) {
  const ChannelDims dims{pressure ? Dim::kPressure : Dim::kTemperature,
                         pressure ? Dim::kPressure : Dim::kTemperatureDelta};
  parse_term_list(w, n, dims, pressure, out, file);
}

// ---------------------------------------------------------------- sensor

FilterSpec parse_filter(const Where& w, const YAML::Node& m, double rate_hz) {
  FilterSpec f;
  if (m.IsScalar()) {
    std::string s = get_string(w, m);
    if (s != "none") fail(w, m, "expected none or a filter mapping");
    return f;
  }
  check_keys(w, m, {"type", "length", "time", "time_constant"});
  std::string type = m["type"] ? get_string(w.child("type"), m["type"]) : "none";
  if (type == "none") f.type = FilterType::None;
  else if (type == "moving_average") f.type = FilterType::MovingAverage;
  else if (type == "repeating_average") f.type = FilterType::RepeatingAverage;
  else if (type == "first_order") f.type = FilterType::FirstOrder;
  else fail(w.child("type"), m["type"], "expected none, moving_average, repeating_average or first_order");
  if (m["length"]) f.length = std::uint32_t(get_int(w.child("length"), m["length"], 1, 65535));
  if (m["time"]) {  // window as a time: length = time * sample rate
    double t = get_quantity(w.child("time"), m["time"], Dim::kTime);
    f.length = std::uint32_t(std::max(1.0, std::round(t * rate_hz)));
  }
  f.time_constant_s = q(w, m, "time_constant", Dim::kTime, 0.0);
  if (f.type == FilterType::FirstOrder && !(f.time_constant_s > 0))
    fail(w.child("time_constant"), m["time_constant"], "expected a time constant > 0 for a first_order filter");
  return f;
}

void parse_range(const Where& w, const YAML::Node& n, Dim dim, double& lo, double& hi) {
  if (!n.IsSequence() || n.size() != 2) fail(w, n, "expected [min, max]");
  lo = get_quantity(w.item(0), n[0], dim);
  hi = get_quantity(w.item(1), n[1], dim);
  if (!(hi > lo)) fail(w.item(1), n[1], "expected max > min");
}

void parse_adc(const Where& w, const YAML::Node& m, ChannelSpec& c) {
  if (m.IsScalar()) {  // adc: 12  (bits)
    c.adc = AdcSpec::unsigned_bits(unsigned(get_int(w, m, 1, 30)));
    return;
  }
  check_keys(
      w, m, {"bits", "headroom", "field_full_scale", "code_at_range_min", "code_at_range_max", "code_min", "code_max"});
  if (m["bits"])
    c.adc = AdcSpec::unsigned_bits(unsigned(get_int(w.child("bits"), m["bits"], 1, 30)), num(w, m, "headroom", 0.0));
  if (m["field_full_scale"]) c.adc = AdcSpec::int16_field(num(w, m, "field_full_scale", 20000.0));
  c.adc.code_at_range_min = num(w, m, "code_at_range_min", c.adc.code_at_range_min);
  c.adc.code_at_range_max = num(w, m, "code_at_range_max", c.adc.code_at_range_max);
  if (m["code_min"]) c.adc.code_min = std::int32_t(get_int(w.child("code_min"), m["code_min"], INT32_MIN, INT32_MAX));
  if (m["code_max"]) c.adc.code_max = std::int32_t(get_int(w.child("code_max"), m["code_max"], INT32_MIN, INT32_MAX));
  if (c.adc.code_max <= c.adc.code_min) fail(w.child("code_max"), m["code_max"], "expected code_max > code_min");
}

void parse_channel_sensor(const Where& w, const YAML::Node& m, bool pressure, ChannelSpec& c) {
  check_keys(w, m, {"enabled",           "range",        "sample_rate",           "adc",
                    "output_steps",      "noise",        "response_time",         "filter",
                    "zero_offset",       "span_error",   "nonlinearity",          "hysteresis",
                    "thermal_zero",      "thermal_span", "reference_temperature", "total_error_band",
                    "compensated_range", "overload",     "overload_safe",         "invalid_output",
                    "catch_up_samples"});
  const Dim abs_dim = pressure ? Dim::kPressure : Dim::kTemperature;
  const Dim delta_dim = pressure ? Dim::kPressure : Dim::kTemperatureDelta;
  if (m["enabled"]) c.enabled = get_bool(w.child("enabled"), m["enabled"]);
  if (m["range"]) parse_range(w.child("range"), m["range"], abs_dim, c.range_min, c.range_max);
  c.sample_rate_hz = q(w, m, "sample_rate", Dim::kFrequency, c.sample_rate_hz);
  positive(w.child("sample_rate"), m["sample_rate"], c.sample_rate_hz, "a sample rate");
  if (m["adc"]) parse_adc(w.child("adc"), m["adc"], c);
  if (m["output_steps"])
    c.output_steps = std::uint32_t(get_int(w.child("output_steps"), m["output_steps"], 0, 1 << 30));
  c.noise_rms = q(w, m, "noise", delta_dim, c.noise_rms);
  if (c.noise_rms < 0) fail(w.child("noise"), m["noise"], "expected noise >= 0");
  c.response_time_constant_s = q(w, m, "response_time", Dim::kTime, c.response_time_constant_s);
  if (m["filter"]) c.filter = parse_filter(w.child("filter"), m["filter"], c.sample_rate_hz);
  ErrorSpec& e = c.errors;
  e.zero_offset = q(w, m, "zero_offset", delta_dim, e.zero_offset);
  e.span_error = num(w, m, "span_error", e.span_error);
  e.nonlinearity = q(w, m, "nonlinearity", delta_dim, e.nonlinearity);
  e.hysteresis = q(w, m, "hysteresis", delta_dim, e.hysteresis);
  e.thermal_zero_per_k = q(w, m, "thermal_zero", delta_dim, e.thermal_zero_per_k);  // per K
  e.thermal_span_per_k = num(w, m, "thermal_span", e.thermal_span_per_k);           // per K
  e.reference_temperature_k = q(w, m, "reference_temperature", Dim::kTemperature, e.reference_temperature_k);
  e.total_error_band = q(w, m, "total_error_band", delta_dim, e.total_error_band);
  if (m["compensated_range"])
    parse_range(w.child("compensated_range"), m["compensated_range"], Dim::kTemperature, e.compensated_min_k,
                e.compensated_max_k);
  if (m["overload"]) {
    Where wo = w.child("overload");
    const YAML::Node& o = m["overload"];
    check_keys(wo, o, {"source", "margin", "hysteresis"});
    if (o["source"]) {
      std::string s = get_string(wo.child("source"), o["source"]);
      if (s == "raw") c.overload.source = OverloadSource::Raw;
      else if (s == "filtered") c.overload.source = OverloadSource::Filtered;
      else fail(wo.child("source"), o["source"], "expected raw or filtered");
    }
    c.overload.margin = q(wo, o, "margin", delta_dim, c.overload.margin);
    c.overload.hysteresis = q(wo, o, "hysteresis", delta_dim, c.overload.hysteresis);
  }
  if (m["overload_safe"]) {  // a maximum, or [min, max]
    const YAML::Node& s = m["overload_safe"];
    if (s.IsSequence()) parse_range(w.child("overload_safe"), s, abs_dim, c.overload.safe_min, c.overload.safe_max);
    else c.overload.safe_max = get_quantity(w.child("overload_safe"), s, abs_dim);
  }
  if (m["invalid_output"]) {
    std::string s = get_string(w.child("invalid_output"), m["invalid_output"]);
    if (s == "hold") c.invalid_output = InvalidOutput::HoldLastValid;
    else if (s == "pass") c.invalid_output = InvalidOutput::PassThrough;
    else fail(w.child("invalid_output"), m["invalid_output"], "expected hold or pass");
  }
  if (m["catch_up_samples"])
    c.catch_up_samples = std::uint32_t(get_int(w.child("catch_up_samples"), m["catch_up_samples"], 0, 1 << 24));
}

// ---------------------------------------------------------------- faults

// The keys of a `faults:` entry.
void check_fault_key(const Where& w, const YAML::Node& key) {
  check_key(w, key,
            {"kind",
             "channel",
             "at",
             "after",
             "duration",
             "period",
             "count",
             "value",
             "drift",
             "amplitude",
             "rate",
             "noise",
             "over_temperature",
             "sdo_delay",
             "drop_every",
             "drop_probability",
             "id",
             "service",
             "cob_id",
             "probability",
             "delay",
             "jitter",
             "bytes",
             "dlc",
             "duty",
             "index",
             "sub",
             "code",
             "ppm",
             "class"});
}

// ---------------------------------------------------------------- network faults

using physics::ErrorClass;
using physics::FrameService;
using physics::NetFaultParams;

// The network keys each network fault kind takes (`period` of error_frames
// is the error frames' period; of the others the occurrences' repeat).
struct NetKeys {
  FaultKind kind;
  std::initializer_list<const char*> keys;
};
const NetKeys kNetKeys[] = {
    {FaultKind::FrameDrop, {"service", "cob_id", "probability"}},
    {FaultKind::FrameDelay, {"service", "cob_id", "probability", "delay", "jitter"}},
    {FaultKind::FrameFreeze, {"service", "cob_id", "probability"}},
    {FaultKind::FrameCorrupt, {"service", "cob_id", "probability", "bytes", "value"}},
    {FaultKind::FrameDlc, {"service", "cob_id", "probability", "dlc"}},
    {FaultKind::FrameDuplicate, {"service", "cob_id", "probability"}},
    {FaultKind::NodeIdCollision, {}},
    {FaultKind::Babbling, {"cob_id", "rate", "duty"}},
    {FaultKind::SdoAbort, {"index", "sub", "code"}},
    {FaultKind::SdoSilent, {"index", "sub"}},
    {FaultKind::SdoToggleError, {"probability"}},
    {FaultKind::ClockDrift, {"ppm"}},
    {FaultKind::ErrorFrames, {"class", "period"}},
};
// Keys no other kind reads with this meaning: refused where they do not belong.
constexpr const char* kNetOnlyKeys[] = {"service", "cob_id", "probability", "delay", "jitter", "bytes", "dlc",
                                        "duty",    "index",  "sub",         "code",  "ppm",    "class"};

const NetKeys* net_keys(FaultKind k) {
  for (const NetKeys& n : kNetKeys)
    if (n.kind == k) return &n;
  return nullptr;
}

bool takes(const NetKeys* n, std::string_view key) {
  if (!n) return false;
  for (const char* k : n->keys)
    if (key == k) return true;
  return false;
}

// tpdo1..tpdo512, heartbeat, emcy, sdo, bootup, lss.
void parse_service(const Where& w, const YAML::Node& n, NetFaultParams& p) {
  const std::string s = get_string(w, n);
  static constexpr std::pair<const char*, FrameService> kNames[] = {{"heartbeat", FrameService::Heartbeat},
                                                                    {"emcy", FrameService::Emcy},
                                                                    {"sdo", FrameService::Sdo},
                                                                    {"bootup", FrameService::BootUp},
                                                                    {"lss", FrameService::Lss}};
  for (const auto& [name, service] : kNames)
    if (s == name) {
      p.service = service;
      return;
    }
  if (s.rfind("tpdo", 0) == 0 && s.size() > 4 && s.size() <= 7 && s[4] != '0' &&
      s.find_first_not_of("0123456789", 4) == std::string::npos && std::stoi(s.substr(4)) <= 512) {
    p.service = FrameService::Tpdo;
    p.tpdo = std::uint16_t(std::stoi(s.substr(4)));
    return;
  }
  fail(w, n, "expected tpdo1..tpdo512, heartbeat, emcy, sdo, bootup or lss");
}

// Byte positions 0..7: one, or a list.
std::uint8_t parse_bytes(const Where& w, const YAML::Node& n) {
  std::uint8_t mask = 0;
  if (n.IsSequence()) {
    if (n.size() == 0) fail(w, n, "expected byte positions 0..7");
    for (std::size_t i = 0; i < n.size(); ++i) mask |= std::uint8_t(1u << get_int(w.item(i), n[i], 0, 7));
    return mask;
  }
  return std::uint8_t(1u << get_int(w, n, 0, 7));
}

ErrorClass parse_error_class(const Where& w, const YAML::Node& n) {
  const std::string s = get_string(w, n);
  static constexpr std::pair<const char*, ErrorClass> kNames[] = {
      {"warning", ErrorClass::Warning}, {"passive", ErrorClass::Passive},
      {"bus_off", ErrorClass::BusOff},  {"restarted", ErrorClass::Restarted},
      {"stuff", ErrorClass::Stuff},     {"form", ErrorClass::Form},
      {"ack", ErrorClass::Ack}};
  for (const auto& [name, c] : kNames)
    if (s == name) return c;
  fail(w, n, "expected warning, passive, bus_off, restarted, stuff, form or ack");
}

void require(const Where& w, const YAML::Node& m, const char* key, FaultKind kind) {
  if (!m[key])
    fail(w.child(key), m, std::string("missing required key '") + key + "' of " + std::string(to_string(kind)));
}

// The network keys of `m` for its kind; refuses those of other kinds.
void parse_net_params(const Where& w, const YAML::Node& m, FaultKind kind, NetFaultParams& p) {
  const NetKeys* allowed = net_keys(kind);
  for (const char* key : kNetOnlyKeys)
    if (m[key] && !takes(allowed, key))
      fail(w.child(key), m[key], "not a parameter of " + std::string(to_string(kind)));
  if (!allowed) return;
  const bool frames = physics::is_frame_fault(kind);
  if (m["service"] && m["cob_id"]) fail(w.child("cob_id"), m["cob_id"], "expected service or cob_id, not both");
  if (m["service"]) parse_service(w.child("service"), m["service"], p);
  if (m["cob_id"]) {
    p.service = FrameService::CobId;
    p.cob_id = std::uint32_t(get_int(w.child("cob_id"), m["cob_id"], 0, 0x1FFFFFFF));
  }
  if (frames && p.service == FrameService::None)
    fail(w, m,
         "missing 'service' (tpdo1..tpdo512, heartbeat, emcy, sdo, bootup, lss) or 'cob_id' of " +
             std::string(to_string(kind)));
  if (m["probability"]) {
    p.probability = get_double(w.child("probability"), m["probability"]);
    if (!(p.probability > 0 && p.probability <= 1))
      fail(w.child("probability"), m["probability"], "expected a probability > 0 and <= 1");
  }
  switch (kind) {
    case FaultKind::FrameDelay:
      require(w, m, "delay", kind);
      p.delay_us = seconds_to_us(get_quantity(w.child("delay"), m["delay"], Dim::kTime));
      p.jitter_us = seconds_to_us(q(w, m, "jitter", Dim::kTime, 0.0));
      if (p.delay_us < 0 || p.jitter_us < 0 || p.delay_us + p.jitter_us == 0)
        fail(w.child("delay"), m["delay"], "expected delay and jitter >= 0, not both 0");
      break;
    case FaultKind::FrameCorrupt:
      if (m["bytes"]) p.bytes = parse_bytes(w.child("bytes"), m["bytes"]);
      if (m["value"]) p.value = int(get_int(w.child("value"), m["value"], 0, 255));
      break;
    case FaultKind::FrameDlc:
      require(w, m, "dlc", kind);
      p.dlc = std::uint8_t(get_int(w.child("dlc"), m["dlc"], 0, 8));
      break;
    case FaultKind::Babbling:
      require(w, m, "cob_id", kind);
      if (bool(m["rate"]) == bool(m["duty"]))
        fail(w, m, "expected rate (frames per second) or duty (0..1) of babbling");
      if (m["rate"]) {
        p.rate_hz = get_quantity(w.child("rate"), m["rate"], Dim::kFrequency);
        if (!(p.rate_hz > 0 && p.rate_hz <= 1e6))
          fail(w.child("rate"), m["rate"], "expected a rate of 1e-6..1e6 frames per second");
      } else {
        p.duty = get_double(w.child("duty"), m["duty"]);
        if (!(p.duty > 0 && p.duty <= 1)) fail(w.child("duty"), m["duty"], "expected a duty cycle > 0 and <= 1");
      }
      break;
    case FaultKind::SdoAbort:
      require(w, m, "index", kind);
      require(w, m, "code", kind);
      p.code = std::uint32_t(get_int(w.child("code"), m["code"], 1, 0xFFFFFFFF));
      [[fallthrough]];
    case FaultKind::SdoSilent:
      if (m["index"]) p.index = std::uint16_t(get_int(w.child("index"), m["index"], 1, 0xFFFF));
      if (m["sub"] && !m["index"]) fail(w.child("sub"), m["sub"], "a sub-index needs an index");
      if (m["sub"]) p.sub = int(get_int(w.child("sub"), m["sub"], 0, 255));
      break;
    case FaultKind::ClockDrift:
      require(w, m, "ppm", kind);
      p.ppm = get_double(w.child("ppm"), m["ppm"]);
      if (!(p.ppm != 0 && p.ppm > -1e5 && p.ppm < 1e5))
        fail(w.child("ppm"), m["ppm"], "expected ppm in -1e5..1e5, not 0");
      break;
    case FaultKind::ErrorFrames:
      require(w, m, "class", kind);
      p.error_class = parse_error_class(w.child("class"), m["class"]);
      p.error_period_us = seconds_to_us(q(w, m, "period", Dim::kTime, 0.0));
      if (p.error_period_us < 0 || (m["period"] && p.error_period_us == 0))
        fail(w.child("period"), m["period"], "expected a period > 0 (omit it: one error frame at the start)");
      break;
    default: break;
  }
}

FaultChannel parse_fault_channel(const Where& w, const YAML::Node& n) {
  if (const std::optional<FaultChannel> c = physics::parse_fault_channel(get_string(w, n))) return *c;
  fail(w, n, "expected pressure, temperature or both");
}

}  // namespace

void parse_fault_timing(const Where& w, const YAML::Node& m, FaultSpec& f) {
  if (m["at"]) f.timing.at_us = seconds_to_us(get_quantity(w.child("at"), m["at"], Dim::kTime));
  f.timing.after_us = seconds_to_us(q(w, m, "after", Dim::kTime, 0.0));
  f.timing.duration_us =
      m["duration"] ? seconds_to_us(get_quantity(w.child("duration"), m["duration"], Dim::kTime)) : -1;
  // error_frames' `period` is the error frames' (parse_net_params).
  if (f.kind != FaultKind::ErrorFrames) f.timing.period_us = seconds_to_us(q(w, m, "period", Dim::kTime, 0.0));
  if (m["count"]) f.timing.count = std::uint32_t(get_int(w.child("count"), m["count"], 0, UINT32_MAX));
  if (f.timing.after_us < 0 || f.timing.period_us < 0) fail(w, m, "expected non-negative 'after' and 'period'");
  // A zero duration is an instant: only a power cycle (an immediate reboot) acts in one.
  if (f.timing.duration_us == 0 && f.kind != FaultKind::PowerCycle)
    fail(w.child("duration"), m["duration"], "expected a duration > 0 (omit it: until the end)");
  if (f.timing.duration_us < -1) fail(w.child("duration"), m["duration"], "expected a duration >= 0");
}

FaultSpec parse_fault(const Where& w, const YAML::Node& m) {
  if (!m.IsMap()) fail(w, m, "expected a mapping");
  for (const auto& kv : m) check_fault_key(w, kv.first);
  FaultSpec f;
  if (!m["kind"]) fail(w.child("kind"), m, "missing required key 'kind'");
  auto kind = parse_fault_kind(get_string(w.child("kind"), m["kind"]));
  if (kind && is_plant_fault(*kind))
    fail(w.child("kind"), m["kind"],
         "expected a node fault (leak, blocked, valve_stuck and input_lost are plant faults: under plants: NAME: "
         "faults:, or armed on the plant)");
  if (!kind)
    fail(w.child("kind"), m["kind"],
         "expected open, short, stuck, drift, spikes, noise_burst, over_temperature, eeprom_error, silent, "
         "power_cycle, bus_off, heartbeat_stop, slow_sdo, sdo_block_drop, frame_drop, frame_delay, frame_freeze, "
         "frame_corrupt, frame_dlc, frame_duplicate, node_id_collision, babbling, sdo_abort, sdo_silent, "
         "sdo_toggle_error, clock_drift or error_frames");
  f.kind = *kind;
  if (m["channel"]) f.channel = parse_fault_channel(w.child("channel"), m["channel"]);
  const bool temperature = f.channel == FaultChannel::Temperature;
  const Dim abs_dim = temperature ? Dim::kTemperature : Dim::kPressure;
  const Dim delta_dim = temperature ? Dim::kTemperatureDelta : Dim::kPressure;
  parse_fault_timing(w, m, f);
  if (m["value"] && f.kind != FaultKind::FrameCorrupt)
    f.stuck_value = get_quantity(w.child("value"), m["value"], abs_dim);
  f.drift_per_s = q(w, m, "drift", delta_dim, 0.0);  // per second
  f.spike_amplitude = q(w, m, "amplitude", delta_dim, 0.0);
  f.spike_rate_hz = q(w, m, "rate", Dim::kFrequency, 0.0);
  f.noise_rms = q(w, m, "noise", delta_dim, 0.0);
  f.over_temperature_k = q(w, m, "over_temperature", Dim::kTemperatureDelta, 0.0);
  f.sdo_delay_us = seconds_to_us(q(w, m, "sdo_delay", Dim::kTime, 0.0));
  if (m["drop_every"]) f.drop_every_n = std::uint32_t(get_int(w.child("drop_every"), m["drop_every"], 0, UINT32_MAX));
  f.drop_probability = num(w, m, "drop_probability", 0.0);
  if (f.drop_probability < 0 || f.drop_probability > 1)
    fail(w.child("drop_probability"), m["drop_probability"], "expected a probability 0..1");
  if (m["id"]) f.id = std::uint32_t(get_int(w.child("id"), m["id"], 0, UINT32_MAX));
  parse_net_params(w, m, f.kind, f.net);
  return f;
}

std::vector<TermSpec> parse_terms(const Where& w, const YAML::Node& n, Dim level, Dim delta, const Medium* medium) {
  std::vector<TermSpec> out;
  parse_term_list(w, n, ChannelDims{level, delta, medium}, false, out, w.file);
  return out;
}

std::string origin_of(const Where& w, const YAML::Node& n) {
  std::string out = w.file;
  if (n.IsDefined() && n.Mark().line >= 0)
    out += ":" + std::to_string(n.Mark().line + 1) + ":" + std::to_string(n.Mark().column + 1);
  return out + ": " + (w.path.empty() ? "(top level)" : w.path);
}

double get_quantity(const Where& w, const YAML::Node& n, Dim dim, const Medium* medium) {
  if (!n.IsScalar()) fail(w, n, std::string("expected ") + expected_units(dim));
  double v = 0, out = 0;
  std::string unit;
  if (!split_number(n.Scalar(), v, unit) || !convert_quantity(v, unit, dim, out, medium) || !std::isfinite(out))
    fail(w, n, std::string("expected ") + expected_units(dim));
  // Times become µs in 64 bits: a bound keeps `at: 1e20 s` from wrapping to "now".
  if (dim == Dim::kTime && std::abs(out) > limits::kMaxSeconds)
    fail(w, n, "expected a time of at most 1e9 s (about 31 years)");
  return out;
}

ProcessSpec default_process() {
  ProcessSpec p;
  p.pressure.push_back(ConstantSpec{5.0e5});
  p.pressure.push_back(OrnsteinUhlenbeckSpec{0.0, 30.0, 0.1e5, kNaN});
  p.temperature.push_back(ConstantSpec{to_kelvin(22.5, TemperatureUnit::degC)});
  p.temperature.push_back(SineSpec{2.5, 1.0 / 600.0, 0.0});
  return p;
}

SensorSpec default_sensor() {
  SensorSpec s;
  s.pressure.range_min = 0.0;
  s.pressure.range_max = 10.0e5;
  s.pressure.sample_rate_hz = 1000.0;
  s.pressure.adc = AdcSpec::unsigned_bits(16, 0.1);
  s.pressure.noise_rms = 0.001e5;
  s.pressure.overload.safe_max = 30.0e5;
  s.temperature.range_min = to_kelvin(-40.0, TemperatureUnit::degC);
  s.temperature.range_max = to_kelvin(125.0, TemperatureUnit::degC);
  s.temperature.sample_rate_hz = 100.0;
  s.temperature.adc = AdcSpec::unsigned_bits(16, 0.1);
  s.temperature.noise_rms = 0.02;
  return s;
}

ProcessSpec parse_process(const Where& w, const YAML::Node& n) {
  ProcessSpec p = default_process();
  if (!n || n.IsNull()) return p;
  check_keys(w, n, {"pressure", "temperature", "gas_volume"});
  if (n["pressure"]) parse_channel_terms(w.child("pressure"), n["pressure"], true, p.pressure, w.file);
  if (n["temperature"]) parse_channel_terms(w.child("temperature"), n["temperature"], false, p.temperature, w.file);
  if (n["gas_volume"]) {
    Where wg = w.child("gas_volume");
    const YAML::Node& g = n["gas_volume"];
    check_keys(wg, g, {"pressure", "temperature", "ambient", "time_constant"});
    if (n["pressure"] || n["temperature"])
      fail(wg, g, "gas_volume defines both channels; remove 'pressure' and 'temperature'");
    GasVolumeSpec gv;
    gv.initial_pressure_pa = q(wg, g, "pressure", Dim::kPressure, gv.initial_pressure_pa);
    gv.initial_temperature_k = q(wg, g, "temperature", Dim::kTemperature, gv.initial_temperature_k);
    gv.ambient_k = g["ambient"] ? parse_setpoint(wg.child("ambient"), g["ambient"], Dim::kTemperature, w.file)
                                : TableSpec{{{0.0, gv.initial_temperature_k}}, Interpolation::Hold, false, 0.0};
    gv.time_constant_s = q(wg, g, "time_constant", Dim::kTime, gv.time_constant_s);
    positive(wg.child("time_constant"), g["time_constant"], gv.time_constant_s, "a time constant");
    p.pressure.clear();
    p.temperature.clear();
    add_gas_volume(p, gv);
  }
  if (std::string e = validate(p); !e.empty()) fail(w, n, "invalid process model: " + e);
  return p;
}

std::vector<TermSpec> parse_channel_model(const Where& w, const YAML::Node& n, Channel channel) {
  std::vector<TermSpec> terms;
  parse_channel_terms(w, n, channel == Channel::Pressure, terms, w.file);
  if (std::string e = validate(channel, terms); !e.empty()) fail(w, n, "invalid process model: " + e);
  return terms;
}

SensorSpec parse_sensor(const Where& w, const YAML::Node& n, const SensorSpec& base) {
  SensorSpec s = base;
  if (!n || n.IsNull()) return s;
  check_keys(w, n, {"pressure", "temperature"});
  if (n["pressure"]) parse_channel_sensor(w.child("pressure"), n["pressure"], true, s.pressure);
  if (n["temperature"]) parse_channel_sensor(w.child("temperature"), n["temperature"], false, s.temperature);
  if (std::string e = validate(s); !e.empty()) fail(w, n, "invalid sensor: " + e);
  return s;
}

std::vector<FaultSpec> parse_faults(const Where& w, const YAML::Node& n) {
  std::vector<FaultSpec> out;
  if (!n || n.IsNull()) return out;
  if (!n.IsSequence()) fail(w, n, "expected a list of faults");
  for (std::size_t i = 0; i < n.size(); ++i) out.push_back(parse_fault(w.item(i), n[i]));
  return out;
}

PhysicsConfig parse_physics_config(const std::string& file, const YAML::Node& doc) {
  const Where root{file, ""};
  PhysicsConfig c;
  c.process = parse_process(root.child("physics"), doc["physics"]);
  c.sensor = parse_sensor(root.child("sensor"), doc["sensor"], default_sensor());
  c.faults = parse_faults(root.child("faults"), doc["faults"]);
  return c;
}

std::vector<physics::TermSpec> parse_channel_model_text(const std::string& source, const std::string& channel_name,
                                                        const std::string& text, physics::Channel channel) {
  return parse_channel_model(Where{source, channel_name}, load_yaml_text(text, source), channel);
}

// Each key is checked before it goes into the entry: only known keys do, so
// the entry's lookups stay short whatever the caller sends.
physics::FaultSpec parse_fault_text(const std::string& source, const std::string& kind,
                                    const std::vector<std::pair<std::string, std::string>>& keys) {
  YAML::Node entry(YAML::NodeType::Map);
  entry["kind"] = kind;
  const Where w{source, ""};
  for (const auto& [key, value] : keys) {
    YAML::Node name(key);
    check_fault_key(w, name);
    check_yaml_size(value, source + ": " + key, limits::kFaultValueBytes);
    try {
      entry[key] = YAML::Load(value);
    } catch (const YAML::ParserException& ex) {
      throw ConfigError(key + ": " + ex.msg);
    }
  }
  return parse_fault(w, entry);
}

}  // namespace cansim::config
