#include "config/plant_config.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "config/fleet.hpp"
#include "config/limits.hpp"
#include "config/physics_config.hpp"
#include "model/device_settings.hpp"

namespace cansim::config {

namespace {

using namespace cansim::physics;

// ---------------------------------------------------------------- quantities

bool split(const std::string& s, double& v, std::string& unit) {
  const char* b = s.c_str();
  char* e = nullptr;
  v = std::strtod(b, &e);
  if (e == b || !std::isfinite(v)) return false;
  std::string rest(e);
  const auto a = rest.find_first_not_of(' ');
  unit = a == std::string::npos ? "" : rest.substr(a);
  while (!unit.empty() && unit.back() == ' ') unit.pop_back();
  return true;
}

// A quantity of `kind` in the plant's medium (a bare number is SI).
double quantity(const Where& w, const YAML::Node& n, QuantityKind kind, const Medium& medium) {
  double v = 0;
  std::string unit;
  if (!n.IsScalar() || !split(n.Scalar(), v, unit))
    fail(w, n,
         "expected " + std::string(kind_name(kind)) +
             (kind == QuantityKind::kNumber ? "" : " like '" + std::string(display_unit(kind).name) + "'"));
  if (unit.empty()) return v;
  const std::optional<Unit> u = find_unit(unit, medium);
  if (!u || u->kind != kind)
    fail(w, n,
         kind == QuantityKind::kNumber ? std::string("expected a number without a unit")
                                       : "expected a " + std::string(kind_name(kind)) + " (" + unit_names(kind) + ")");
  return from_unit(v, *u);
}

double quantity_or(const Where& w, const YAML::Node& m, const char* key, QuantityKind kind, const Medium& medium,
                   double def) {
  return m[key] ? quantity(w.child(key), m[key], kind, medium) : def;
}

// A quantity of any kind (an offset, a limit, a table point): SI and its kind.
std::pair<double, QuantityKind> any_quantity(const Where& w, const YAML::Node& n, const Medium& medium) {
  double v = 0;
  std::string unit;
  if (!n.IsScalar() || !split(n.Scalar(), v, unit)) fail(w, n, "expected a number or a quantity like '2 bar'");
  if (unit.empty()) return {v, QuantityKind::kNumber};
  const std::optional<Unit> u = find_unit(unit, medium);
  if (!u) fail(w, n, "expected a known unit (bar, degC, %, g/s, W, ...)");
  return {from_unit(v, *u), u->kind};
}

double any_or(const Where& w, const YAML::Node& m, const char* key, const Medium& medium, double def) {
  return m[key] ? any_quantity(w.child(key), m[key], medium).first : def;
}

double time_or(const Where& w, const YAML::Node& m, const char* key, double def) {
  return m[key] ? get_quantity(w.child(key), m[key], Dim::kTime) : def;
}

// A rate: "<quantity>/s" or "/min" (a bare number: SI per second).
double rate(const Where& w, const YAML::Node& n, const Medium& medium) {
  if (!n.IsScalar()) fail(w, n, "expected a rate like '0.5 bar/s'");
  std::string s = n.Scalar();
  double per = 1.0;
  for (auto [suffix, seconds] : {std::pair{"/s", 1.0}, {"/min", 60.0}, {"/h", 3600.0}}) {
    const std::string x(suffix);
    if (s.size() > x.size() && s.compare(s.size() - x.size(), x.size(), x) == 0) {
      s.resize(s.size() - x.size());
      per = seconds;
      break;
    }
  }
  YAML::Node q(s);
  double v = 0;
  std::string unit;
  if (!split(s, v, unit)) fail(w, n, "expected a rate like '0.5 bar/s'");
  if (unit.empty()) return v / per;
  const std::optional<Unit> u = find_unit(unit, medium);
  if (!u) fail(w, n, "expected a rate like '0.5 bar/s' (a known unit per s, min or h)");
  return v * u->factor / per;  // a rate of a difference: no offset
}

bool is_name(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  return true;
}

// A block input: a constant (a quantity of `kind`) or a name.
PlantSignal signal(const Where& w, const YAML::Node& n, QuantityKind kind, const Medium& medium) {
  if (!n.IsScalar()) fail(w, n, "expected a name (an input, BLOCK or BLOCK.OUTPUT) or a constant");
  const std::string& s = n.Scalar();
  double v = 0;
  std::string unit;
  if (split(s, v, unit)) return PlantSignal{"", quantity(w, n, kind, medium), origin_of(w, n)};
  if (!is_name(s)) fail(w, n, "expected a name (an input, BLOCK or BLOCK.OUTPUT) or a constant");
  return PlantSignal{s, 0.0, origin_of(w, n)};
}

PlantSignal signal_or(const Where& w, const YAML::Node& m, const char* key, QuantityKind kind, const Medium& medium,
                      PlantSignal def) {
  return m[key] ? signal(w.child(key), m[key], kind, medium) : def;
}

PlantSignal required_signal(const Where& w, const YAML::Node& m, const char* key, QuantityKind kind,
                            const Medium& medium) {
  if (!m[key]) fail(w.child(key), m, std::string("missing required key '") + key + "'");
  return signal(w.child(key), m[key], kind, medium);
}

std::vector<PlantSignal> signals(const Where& w, const YAML::Node& n, QuantityKind kind, const Medium& medium) {
  std::vector<PlantSignal> out;
  if (!n) return out;
  if (n.IsScalar()) {
    out.push_back(signal(w, n, kind, medium));
    return out;
  }
  if (!n.IsSequence()) fail(w, n, "expected a name or a list of names");
  for (std::size_t i = 0; i < n.size(); ++i) out.push_back(signal(w.item(i), n[i], kind, medium));
  return out;
}

double positive(const Where& w, const YAML::Node& n, double v, const char* what) {
  if (!(v > 0)) fail(w, n, std::string("expected ") + what + " > 0");
  return v;
}

// The Dim of the term parser for an input's kind (time inputs).
std::pair<Dim, Dim> dims_of(QuantityKind k) {
  switch (k) {
    case QuantityKind::kPressure: return {Dim::kPressure, Dim::kPressure};
    case QuantityKind::kTemperature: return {Dim::kTemperature, Dim::kTemperatureDelta};
    case QuantityKind::kMassFlow: return {Dim::kMassFlow, Dim::kMassFlow};
    case QuantityKind::kMass: return {Dim::kMass, Dim::kMass};
    case QuantityKind::kPower: return {Dim::kPower, Dim::kPower};
    case QuantityKind::kTime: return {Dim::kTime, Dim::kTime};
    case QuantityKind::kVolume: return {Dim::kVolume, Dim::kVolume};
    case QuantityKind::kArea: return {Dim::kArea, Dim::kArea};
    case QuantityKind::kLength: return {Dim::kLength, Dim::kLength};
    case QuantityKind::kDensity: return {Dim::kDensity, Dim::kDensity};
    default: return {Dim::kNumber, Dim::kNumber};
  }
}

// ---------------------------------------------------------------- medium

Medium parse_medium(const Where& w, const YAML::Node& n) {
  if (!n) return Medium{};
  if (n.IsScalar()) {
    if (auto m = named_medium(n.Scalar())) return *m;
    fail(w, n, "expected a medium: " + medium_names() + ", {gas: {r, gamma}} or {liquid: {density}}");
  }
  check_keys(w, n, {"gas", "liquid"});
  if (n["gas"] && n["liquid"]) fail(w, n, "expected gas or liquid, not both");
  if (const YAML::Node& g = n["gas"]) {
    const Where wg = w.child("gas");
    check_keys(wg, g, {"r", "gamma"});
    Medium m;
    m.name = "gas";
    m.r_specific = positive(wg.child("r"), g["r"], g["r"] ? get_double(wg.child("r"), g["r"]) : 287.05,
                            "a gas constant (J/(kg K))");
    m.gamma = g["gamma"] ? get_double(wg.child("gamma"), g["gamma"]) : 1.4;
    if (!(m.gamma > 1.0)) fail(wg.child("gamma"), g["gamma"], "expected a heat capacity ratio > 1");
    return m;
  }
  const Where wl = w.child("liquid");
  const YAML::Node& l = n["liquid"];
  if (!l || !l.IsMap()) fail(wl, n, "expected {density: ...}");
  check_keys(wl, l, {"density"});
  Medium m;
  m.gas = false;
  m.name = "liquid";
  m.density = positive(wl.child("density"), l["density"],
                       quantity_or(wl, l, "density", QuantityKind::kDensity, Medium{}, 1000.0), "a density");
  return m;
}

// ---------------------------------------------------------------- blocks

struct BlockArgs {
  const Where& w;
  const YAML::Node& m;
  const Medium& medium;
  void keys(std::initializer_list<const char*> known) const { check_keys(w, m, known); }
  double q(const char* key, QuantityKind k, double def) const { return quantity_or(w, m, key, k, medium, def); }
  double any(const char* key, double def) const { return any_or(w, m, key, medium, def); }
  double time(const char* key, double def) const { return time_or(w, m, key, def); }
  double number(const char* key, double def) const { return m[key] ? get_double(w.child(key), m[key]) : def; }
  PlantSignal sig(const char* key, QuantityKind k, PlantSignal def) const {
    return signal_or(w, m, key, k, medium, def);
  }
  PlantSignal in(QuantityKind k = QuantityKind::kNumber) const { return required_signal(w, m, "in", k, medium); }
  double pos(const char* key, double v, const char* what) const { return positive(w.child(key), m[key], v, what); }
};

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using K = QuantityKind;

BlockParams gas_volume(const BlockArgs& a) {
  a.keys({"type", "volume", "pressure", "temperature", "inflow", "outflow"});
  if (!a.m["volume"]) fail(a.w.child("volume"), a.m, "missing required key 'volume'");
  GasVolumeBlock g;
  g.volume_m3 = a.pos("volume", a.q("volume", K::kVolume, 0), "a volume");
  g.initial_pressure_pa = a.pos("pressure", a.q("pressure", K::kPressure, kAmbientPressurePa), "an absolute pressure");
  if (const YAML::Node& t = a.m["temperature"]) {
    const PlantSignal s = signal(a.w.child("temperature"), t, K::kTemperature, a.medium);
    if (s.is_constant()) g.temperature_k = a.pos("temperature", s.constant, "an absolute temperature");
    else g.temperature = s;
  }
  g.inflow = signals(a.w.child("inflow"), a.m["inflow"], K::kMassFlow, a.medium);
  g.outflow = signals(a.w.child("outflow"), a.m["outflow"], K::kMassFlow, a.medium);
  return g;
}

BlockParams valve(const BlockArgs& a) {
  a.keys({"type", "kv", "cv", "area", "diameter", "discharge", "linear_below", "upstream", "downstream", "opening",
          "temperature"});
  ValveBlock v;
  const int laws = int(bool(a.m["kv"])) + int(bool(a.m["cv"])) + int(bool(a.m["area"])) + int(bool(a.m["diameter"]));
  if (laws != 1) fail(a.w, a.m, "expected one of kv (m3/h), cv (US gal/min), area or diameter");
  if (a.m["kv"]) v.kv = a.number("kv", 0);
  if (a.m["cv"]) v.kv = 0.865 * a.number("cv", 0);  // Kv = 0.865 Cv (EN 60534)
  if (a.m["kv"] || a.m["cv"]) {
    if (!(v.kv >= 0))
      fail(a.w.child(a.m["kv"] ? "kv" : "cv"), a.m[a.m["kv"] ? "kv" : "cv"], "expected a flow coefficient >= 0");
  } else {
    v.law = ValveBlock::Law::kOrifice;
    if (a.m["area"]) v.area_m2 = a.pos("area", a.q("area", K::kArea, 0), "an area");
    else {
      const double d = a.pos("diameter", a.q("diameter", K::kLength, 0), "a diameter");
      v.area_m2 = 0.25 * 3.14159265358979323846 * d * d;
    }
    v.discharge = a.number("discharge", v.discharge);
    if (!(v.discharge > 0 && v.discharge <= 1))
      fail(a.w.child("discharge"), a.m["discharge"], "expected a discharge coefficient in (0, 1]");
  }
  v.linear_below_pa =
      a.pos("linear_below", a.q("linear_below", K::kPressure, v.linear_below_pa), "a pressure difference");
  v.upstream = a.sig("upstream", K::kPressure, v.upstream);
  v.downstream = a.sig("downstream", K::kPressure, v.downstream);
  v.opening = a.sig("opening", K::kFraction, v.opening);
  v.temperature = a.sig("temperature", K::kTemperature, v.temperature);
  return v;
}

BlockParams pump(const BlockArgs& a) {
  a.keys({"type", "flow", "curve", "speed", "inlet", "outlet"});
  PumpBlock p;
  if (!a.m["flow"] && !a.m["curve"]) fail(a.w, a.m, "expected flow (at full speed) or a curve");
  p.nominal_flow_kgs = a.q("flow", K::kMassFlow, 0.0);
  if (p.nominal_flow_kgs < 0) fail(a.w.child("flow"), a.m["flow"], "expected a flow >= 0");
  if (const YAML::Node& c = a.m["curve"]) {
    const Where wc = a.w.child("curve");
    if (!c.IsSequence() || c.size() == 0) fail(wc, c, "expected a list of [pressure difference, flow] at full speed");
    for (std::size_t i = 0; i < c.size(); ++i) {
      const Where wi = wc.item(i);
      if (!c[i].IsSequence() || c[i].size() != 2) fail(wi, c[i], "expected a [pressure difference, flow] pair");
      const double dp = quantity(wi.item(0), c[i][0], K::kPressure, a.medium);
      const double q = quantity(wi.item(1), c[i][1], K::kMassFlow, a.medium);
      if (i > 0 && !(dp > p.curve.back().t_s)) fail(wi.item(0), c[i][0], "expected increasing pressure differences");
      p.curve.push_back({dp, q});
    }
  }
  p.speed = a.sig("speed", K::kFraction, p.speed);
  p.inlet = a.sig("inlet", K::kPressure, p.inlet);
  p.outlet = a.sig("outlet", K::kPressure, p.outlet);
  return p;
}

BlockParams line(const BlockArgs& a) {
  a.keys({"type", "in", "delay"});
  return LineBlock{a.in(K::kMassFlow), a.pos("delay", a.time("delay", 0.1), "a delay")};
}

BlockParams heat_source(const BlockArgs& a) {
  a.keys({"type", "time_constant", "gain", "initial", "power", "ambient"});
  HeatSourceBlock h;
  h.time_constant_s = a.pos("time_constant", a.time("time_constant", h.time_constant_s), "a time constant");
  if (a.m["gain"]) {  // K/W (a bare number or "0.05 K/W")
    std::string s = a.m["gain"].IsScalar() ? a.m["gain"].Scalar() : "";
    if (s.size() > 3 && s.compare(s.size() - 3, 3, "K/W") == 0) s.resize(s.size() - 3);
    char* end = nullptr;
    h.gain_k_per_w = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || !std::isfinite(h.gain_k_per_w))
      fail(a.w.child("gain"), a.m["gain"], "expected a gain in K/W");
  }
  h.initial_k = a.q("initial", K::kTemperature, kNaN);
  h.power = a.sig("power", K::kPower, h.power);
  h.ambient = a.sig("ambient", K::kTemperature, h.ambient);
  return h;
}

BlockParams gain(const BlockArgs& a) {
  a.keys({"type", "in", "k", "unit"});
  return GainBlock{a.in(), a.number("k", 1.0)};
}

BlockParams offset(const BlockArgs& a) {
  a.keys({"type", "in", "offset", "unit"});
  return OffsetBlock{a.in(), a.any("offset", 0.0)};
}

BlockParams sum(const BlockArgs& a) {
  a.keys({"type", "add", "subtract", "unit"});
  SumBlock s{signals(a.w.child("add"), a.m["add"], K::kNumber, a.medium),
             signals(a.w.child("subtract"), a.m["subtract"], K::kNumber, a.medium)};
  if (s.add.empty() && s.subtract.empty()) fail(a.w, a.m, "expected add: and / or subtract: signals");
  return s;
}

BlockParams lag(const BlockArgs& a) {
  a.keys({"type", "in", "time_constant", "gain", "initial", "unit"});
  return LagBlock{a.in(), a.pos("time_constant", a.time("time_constant", 1.0), "a time constant"),
                  a.number("gain", 1.0), a.any("initial", kNaN)};
}

BlockParams second_order(const BlockArgs& a) {
  a.keys({"type", "in", "natural_frequency", "damping", "gain", "initial", "unit"});
  const double f = a.m["natural_frequency"]
                       ? get_quantity(a.w.child("natural_frequency"), a.m["natural_frequency"], Dim::kFrequency)
                       : 1.0;
  return SecondOrderBlock{a.in(), a.pos("natural_frequency", f, "a natural frequency"),
                          a.pos("damping", a.number("damping", 0.7), "a damping ratio"), a.number("gain", 1.0),
                          a.any("initial", kNaN)};
}

BlockParams integrator(const BlockArgs& a) {
  a.keys({"type", "in", "gain", "min", "max", "initial", "unit"});
  IntegratorBlock i{a.in(), a.number("gain", 1.0), a.any("min", -std::numeric_limits<double>::infinity()),
                    a.any("max", std::numeric_limits<double>::infinity()), 0.0};
  if (!(i.min <= i.max)) fail(a.w.child("max"), a.m["max"], "expected max >= min");
  i.initial = a.any("initial", std::clamp(0.0, i.min, i.max));
  if (i.initial < i.min || i.initial > i.max)
    fail(a.w.child("initial"), a.m["initial"], "expected an initial value within [min, max]");
  return i;
}

BlockParams rate_limit(const BlockArgs& a) {
  a.keys({"type", "in", "rise", "fall", "rate", "initial", "unit"});
  RateLimitBlock r{a.in()};
  if (a.m["rate"]) r.rise_per_s = r.fall_per_s = rate(a.w.child("rate"), a.m["rate"], a.medium);
  if (a.m["rise"]) r.rise_per_s = rate(a.w.child("rise"), a.m["rise"], a.medium);
  if (a.m["fall"]) r.fall_per_s = rate(a.w.child("fall"), a.m["fall"], a.medium);
  if (!a.m["rate"] && !a.m["rise"] && !a.m["fall"]) fail(a.w, a.m, "expected rate (or rise and fall)");
  positive(a.w.child("rise"), a.m["rise"] ? a.m["rise"] : a.m["rate"], r.rise_per_s, "a rise rate");
  positive(a.w.child("fall"), a.m["fall"] ? a.m["fall"] : a.m["rate"], r.fall_per_s, "a fall rate");
  r.initial = a.any("initial", kNaN);
  return r;
}

BlockParams saturation(const BlockArgs& a) {
  a.keys({"type", "in", "min", "max", "unit"});
  if (!a.m["min"] && !a.m["max"]) fail(a.w, a.m, "expected min and / or max");
  SaturationBlock s{a.in(), a.any("min", -std::numeric_limits<double>::infinity()),
                    a.any("max", std::numeric_limits<double>::infinity())};
  if (!(s.min < s.max)) fail(a.w.child("max"), a.m["max"], "expected max > min");
  return s;
}

BlockParams dead_time(const BlockArgs& a) {
  a.keys({"type", "in", "delay", "initial", "unit"});
  return DeadTimeBlock{a.in(), a.pos("delay", a.time("delay", 0.1), "a delay"), a.any("initial", kNaN)};
}

BlockParams table(const BlockArgs& a) {
  a.keys({"type", "in", "points", "unit"});
  const YAML::Node& pts = a.m["points"];
  const Where wp = a.w.child("points");
  if (!pts || !pts.IsSequence() || pts.size() == 0) fail(wp, pts ? pts : a.m, "expected a list of [in, out] points");
  TableBlock t{a.in(), {}};
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Where wi = wp.item(i);
    if (!pts[i].IsSequence() || pts[i].size() != 2) fail(wi, pts[i], "expected an [in, out] pair");
    const double x = any_quantity(wi.item(0), pts[i][0], a.medium).first;
    const double y = any_quantity(wi.item(1), pts[i][1], a.medium).first;
    if (i > 0 && !(x > t.points.back().t_s)) fail(wi.item(0), pts[i][0], "expected increasing inputs");
    t.points.push_back({x, y});
  }
  return t;
}

using BlockParser = BlockParams (*)(const BlockArgs&);
constexpr std::pair<const char*, BlockParser> kBlocks[] = {
    {"gas_volume", gas_volume},
    {"valve", valve},
    {"orifice", valve},
    {"pump", pump},
    {"compressor", pump},
    {"line", line},
    {"heat_source", heat_source},
    {"gain", gain},
    {"offset", offset},
    {"sum", sum},
    {"lag", lag},
    {"first_order", lag},
    {"second_order", second_order},
    {"integrator", integrator},
    {"rate_limit", rate_limit},
    {"saturation", saturation},
    {"dead_time", dead_time},
    {"table", table},
};

std::string block_types() {
  std::string out;
  for (const auto& [name, parse] : kBlocks) out += (out.empty() ? "" : ", ") + std::string(name);
  return out;
}

BlockSpec parse_block(const Where& w, const std::string& name, const YAML::Node& m, const Medium& medium) {
  if (!m.IsMap()) fail(w, m, "expected a block mapping like {type: lag, in: u, time_constant: 1 s}");
  if (!m["type"]) fail(w.child("type"), m, "missing required key 'type' (" + block_types() + ")");
  const std::string type = get_string(w.child("type"), m["type"]);
  for (const auto& [tname, parse] : kBlocks) {
    if (type != tname) continue;
    BlockSpec b{name, parse(BlockArgs{w, m, medium}), std::nullopt, origin_of(w, m)};
    if (const YAML::Node& u = m["unit"]) {
      const std::string unit = get_string(w.child("unit"), u);
      const std::optional<Unit> found = find_unit(unit, medium);
      if (!found) fail(w.child("unit"), u, "expected a unit (bar, degC, %, g/s, W, ...)");
      b.kind = found->kind;
    }
    return b;
  }
  fail(w.child("type"), m["type"], "unknown block type (expected " + block_types() + ")");
}

// ---------------------------------------------------------------- inputs

std::string hex(unsigned v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, v);
  return buf;
}

CanSignal parse_frame(const Where& w, const YAML::Node& f, std::string& interface) {
  if (!f.IsMap()) fail(w, f, "expected a frame mapping {interface, id, start or byte, length, type, ...}");
  check_keys(w, f, {"interface", "id", "extended", "start", "byte", "length", "type", "byte_order", "scale", "offset"});
  if (!f["interface"]) fail(w.child("interface"), f, "missing required key 'interface'");
  if (!f["id"]) fail(w.child("id"), f, "missing required key 'id'");
  interface = get_string(w.child("interface"), f["interface"]);
  CanSignal s;
  s.extended = f["extended"] && get_bool(w.child("extended"), f["extended"]);
  s.can_id = std::uint32_t(get_int(w.child("id"), f["id"], 0, s.extended ? 0x1FFFFFFF : 0x7FF));
  if (f["type"]) {
    const std::string t = get_string(w.child("type"), f["type"]);
    if (t == "unsigned") s.type = CanSignal::Type::kUnsigned;
    else if (t == "signed") s.type = CanSignal::Type::kSigned;
    else if (t == "real32" || t == "REAL32") s.type = CanSignal::Type::kReal32;
    else fail(w.child("type"), f["type"], "expected unsigned, signed or real32");
  }
  s.length = std::uint8_t(f["length"] ? get_int(w.child("length"), f["length"], 1, 64)
                                      : (s.type == CanSignal::Type::kReal32 ? 32 : 8));
  if (f["byte_order"]) {
    const std::string o = get_string(w.child("byte_order"), f["byte_order"]);
    if (o == "little" || o == "little_endian" || o == "intel") s.little_endian = true;
    else if (o == "big" || o == "big_endian" || o == "motorola") s.little_endian = false;
    else fail(w.child("byte_order"), f["byte_order"], "expected little (Intel) or big (Motorola)");
  }
  if (f["start"] && f["byte"]) fail(w.child("byte"), f["byte"], "expected start or byte, not both");
  if (f["start"]) s.start = std::uint16_t(get_int(w.child("start"), f["start"], 0, 63));
  if (f["byte"]) {  // byte-aligned: the field's first byte (its least / most significant one)
    const auto b = std::uint16_t(get_int(w.child("byte"), f["byte"], 0, 7));
    s.start = std::uint16_t(s.little_endian ? 8 * b : 8 * b + 7);
  }
  s.scale = f["scale"] ? get_double(w.child("scale"), f["scale"]) : 1.0;
  s.offset = f["offset"] ? get_double(w.child("offset"), f["offset"]) : 0.0;
  if (!std::isfinite(s.scale) || s.scale == 0) fail(w.child("scale"), f["scale"], "expected a finite, non-zero scale");
  if (const char* e = s.invalid()) fail(w, f, e);
  return s;
}

void parse_node_source(const Where& w, const YAML::Node& n, PlantInputBinding& b) {
  if (!n.IsMap()) fail(w, n, "expected {name: NODE, object: 0xINDEX:SUB} or {name: NODE, output: N}");
  check_keys(w, n, {"name", "object", "output"});
  if (!n["name"]) fail(w.child("name"), n, "missing required key 'name'");
  b.node = get_string(w.child("name"), n["name"]);
  if (bool(n["object"]) == bool(n["output"]))
    fail(w, n, "expected object (written by a master) or output (the node's moving output)");
  if (n["output"]) {
    b.kind = PlantInputBinding::Kind::kOutput;
    b.output = unsigned(get_int(w.child("output"), n["output"], 1, 64));
    return;
  }
  b.kind = PlantInputBinding::Kind::kObject;
  const Where wo = w.child("object");
  const std::string text = get_string(wo, n["object"]);
  const auto colon = text.find(':');
  std::int64_t index = 0, sub = 0;
  if (!parse_int_literal(text.substr(0, colon), index) || index < 0 || index > 0xFFFF ||
      (colon != std::string::npos && (!parse_int_literal(text.substr(colon + 1), sub) || sub < 0 || sub > 0xFF)))
    fail(wo, n["object"], "expected INDEX:SUB like 0x6411:01");
  b.index = std::uint16_t(index);
  b.sub = std::uint8_t(sub);
}

std::string describe(const PlantInputBinding& b) {
  switch (b.kind) {
    case PlantInputBinding::Kind::kFrame: {
      const CanSignal& s = b.signal;
      return "frame " + b.interface + " " + hex(s.can_id, s.extended ? 8 : 3) + " bit " + std::to_string(s.start) +
             " +" + std::to_string(s.length) + (s.little_endian ? " little" : " big") +
             (s.type == CanSignal::Type::kReal32   ? " real32"
              : s.type == CanSignal::Type::kSigned ? " signed"
                                                   : " unsigned");
    }
    case PlantInputBinding::Kind::kObject:
      return "object " + hex(b.index, 4) + ":" + hex(b.sub, 2).substr(2) + " of node " + b.node;
    case PlantInputBinding::Kind::kOutput: return "output " + std::to_string(b.output) + " of node " + b.node;
  }
  return "";
}

PlantInputSpec parse_input(const Where& w, const std::string& name, const YAML::Node& m, const Medium& medium,
                           const std::string& plant, std::vector<PlantInputBinding>& bindings, std::size_t index) {
  if (!m.IsMap()) fail(w, m, "expected an input mapping like {unit: '%', frame: {...}}");
  check_keys(w, m, {"unit", "initial", "timeout", "on_timeout", "frame", "node", "time", "plant", "scale", "offset"});
  PlantInputSpec in;
  in.name = name;
  in.origin = origin_of(w, m);
  Unit unit{"", QuantityKind::kNumber, 1.0};
  if (const YAML::Node& u = m["unit"]) {
    in.unit = get_string(w.child("unit"), u);
    const std::optional<Unit> found = find_unit(in.unit, medium);
    if (!found) fail(w.child("unit"), u, "expected a unit (%, bar, degC, g/s, Nl/min, W, ...)");
    unit = *found;
    in.kind = found->kind;
  }
  in.initial = quantity_or(w, m, "initial", in.kind, medium,
                           in.kind == QuantityKind::kPressure      ? kAmbientPressurePa
                           : in.kind == QuantityKind::kTemperature ? kRoomTemperatureK
                                                                   : 0.0);
  if (m["timeout"]) {
    in.timeout_us = seconds_to_us(get_quantity(w.child("timeout"), m["timeout"], Dim::kTime));
    if (in.timeout_us <= 0) fail(w.child("timeout"), m["timeout"], "expected a timeout > 0");
  }
  if (const YAML::Node& t = m["on_timeout"]) {
    if (!m["timeout"]) fail(w.child("on_timeout"), t, "expected a timeout: for on_timeout");
    if (!(t.IsScalar() && t.Scalar() == "hold")) in.on_timeout = quantity(w.child("on_timeout"), t, in.kind, medium);
  }
  const int sources = int(bool(m["frame"])) + int(bool(m["node"])) + int(bool(m["time"])) + int(bool(m["plant"]));
  if (sources > 1) fail(w, m, "expected one source: frame, node, time or plant (none: set through the control API)");
  if ((m["scale"] || m["offset"]) && !m["node"])
    fail(w.child(m["scale"] ? "scale" : "offset"), m[m["scale"] ? "scale" : "offset"],
         "scale and offset apply to a node's object or output (a frame has its own)");
  PlantInputBinding b;
  b.plant = plant;
  b.input = name;
  b.input_index = index;
  b.unit = unit;
  b.origin = in.origin;
  if (const YAML::Node& f = m["frame"]) {
    b.kind = PlantInputBinding::Kind::kFrame;
    b.signal = parse_frame(w.child("frame"), f, b.interface);
    b.origin = origin_of(w.child("frame"), f);
  } else if (const YAML::Node& n = m["node"]) {
    parse_node_source(w.child("node"), n, b);
    b.scale = m["scale"] ? get_double(w.child("scale"), m["scale"]) : 1.0;
    b.offset = m["offset"] ? get_double(w.child("offset"), m["offset"]) : 0.0;
    b.origin = origin_of(w.child("node"), n);
    if (b.kind == PlantInputBinding::Kind::kOutput) in.source = PlantInputSpec::Source::kExternal;
  } else if (const YAML::Node& t = m["time"]) {
    in.source = PlantInputSpec::Source::kTime;
    const auto [level, delta] = dims_of(in.kind);
    in.terms = parse_terms(w.child("time"), t, level, delta, &medium);
    in.description = "time terms";
  } else if (const YAML::Node& p = m["plant"]) {
    in.source = PlantInputSpec::Source::kPlant;
    in.plant_ref = get_string(w.child("plant"), p);
    in.description = "plant " + in.plant_ref;
  } else {
    in.description = "the control API";
  }
  if (m["frame"] || m["node"]) {
    in.description = describe(b);
    bindings.push_back(b);
  }
  return in;
}

// ---------------------------------------------------------------- faults

void check_plant_fault_key(const Where& w, const YAML::Node& key) {
  check_key(w, key, {"kind", "target", "at", "after", "duration", "period", "count", "kv", "flow", "id"});
}

PlantFaultSpec parse_plant_fault(const Where& w, const YAML::Node& m, const Medium& medium) {
  if (!m.IsMap()) fail(w, m, "expected a mapping {kind, target, ...}");
  for (const auto& kv : m) check_plant_fault_key(w, kv.first);
  if (!m["kind"]) fail(w.child("kind"), m, "missing required key 'kind'");
  const std::optional<FaultKind> kind = parse_fault_kind(get_string(w.child("kind"), m["kind"]));
  if (!kind || !is_plant_fault(*kind))
    fail(w.child("kind"), m["kind"], "expected leak, blocked, valve_stuck or input_lost");
  if (!m["target"]) fail(w.child("target"), m, "missing required key 'target' (a block or an input of the plant)");
  PlantFaultSpec f;
  f.fault.kind = *kind;
  f.target = get_string(w.child("target"), m["target"]);
  f.origin = origin_of(w, m);
  parse_fault_timing(w, m, f.fault);
  if ((m["kv"] || m["flow"]) && *kind != FaultKind::Leak)
    fail(w.child(m["kv"] ? "kv" : "flow"), m[m["kv"] ? "kv" : "flow"], "kv and flow are a leak's");
  if (m["kv"]) f.fault.leak_kv = get_double(w.child("kv"), m["kv"]);
  f.fault.leak_flow_kgs = quantity_or(w, m, "flow", QuantityKind::kMassFlow, medium, 0.0);
  if (*kind == FaultKind::Leak && !(f.fault.leak_kv > 0) && !(f.fault.leak_flow_kgs > 0))
    fail(w, m, "expected a leak's kv (of the hole, m3/h) or flow (a constant outflow) > 0");
  if (m["id"]) f.fault.id = std::uint32_t(get_int(w.child("id"), m["id"], 0, UINT32_MAX));
  return f;
}

PlantSpec parse_plant(const Where& w, const std::string& name, const YAML::Node& m,
                      std::vector<PlantInputBinding>& bindings) {
  if (!m.IsMap()) fail(w, m, "expected a plant mapping with blocks: (and inputs:, step:, medium:, faults:)");
  check_keys(w, m, {"step", "medium", "inputs", "blocks", "faults"});
  PlantSpec p;
  p.name = name;
  p.origin = origin_of(w, m);
  if (m["step"]) {
    const double s = get_quantity(w.child("step"), m["step"], Dim::kTime);
    if (!(s >= 10e-6 && s <= 1.0)) fail(w.child("step"), m["step"], "expected a step from 10 us to 1 s");
    p.step_us = seconds_to_us(s);
  }
  p.medium = parse_medium(w.child("medium"), m["medium"]);
  if (const YAML::Node& ins = m["inputs"]) {
    const Where wi = w.child("inputs");
    if (!ins.IsMap()) fail(wi, ins, "expected a mapping of input names to inputs");
    for (const auto& kv : ins) {
      const std::string in_name = get_string(wi, kv.first);
      p.inputs.push_back(parse_input(wi.child(in_name), in_name, kv.second, p.medium, name, bindings, p.inputs.size()));
    }
  }
  const YAML::Node& blocks = m["blocks"];
  const Where wb = w.child("blocks");
  if (!blocks) fail(wb, m, "missing required key 'blocks'");
  if (!blocks.IsMap() || blocks.size() == 0) fail(wb, blocks, "expected a mapping of block names to blocks");
  for (const auto& kv : blocks) {
    const std::string b_name = get_string(wb, kv.first);
    p.blocks.push_back(parse_block(wb.child(b_name), b_name, kv.second, p.medium));
  }
  if (const YAML::Node& fs = m["faults"]) {
    const Where wf = w.child("faults");
    if (!fs.IsSequence()) fail(wf, fs, "expected a list of plant faults");
    for (std::size_t i = 0; i < fs.size(); ++i) p.faults.push_back(parse_plant_fault(wf.item(i), fs[i], p.medium));
  }
  return p;
}

// ---------------------------------------------------------------- checks

ConfigError plant_error(const PlantError& e) { return ConfigError(e.what()); }

const NodeConfig* find_node(const FleetConfig& fleet, const std::string& ref, std::string& why) {
  for (const NodeConfig& n : fleet.nodes)
    if (n.key == ref) return &n;
  std::vector<const NodeConfig*> named;
  for (const NodeConfig& n : fleet.nodes) {
    if (n.name == ref) named.push_back(&n);
    if (n.name + "/" + std::to_string(n.index) == ref) return &n;
  }
  if (named.size() == 1) return named[0];
  why = named.empty() ? "no node '" + ref + "' in the fleet (a node's name, name/INDEX or key)"
                      : "'" + ref + "' names " + std::to_string(named.size()) + " nodes: expected NAME/INDEX";
  return nullptr;
}

void check_binding(FleetConfig& fleet, PlantInputBinding& b) {
  const std::string at = b.origin + ": ";
  if (b.kind == PlantInputBinding::Kind::kFrame) {
    if (!fleet.interface(b.interface)) {
      std::string names;
      for (const auto& i : fleet.interfaces) names += (names.empty() ? "" : ", ") + i.name;
      throw ConfigError(at + "expected an interface of the fleet (" + names + "), got '" + b.interface + "'");
    }
    return;
  }
  std::string why;
  const NodeConfig* n = find_node(fleet, b.node, why);
  if (!n) throw ConfigError(at + why);
  b.node_key = n->key;
  const model::Profile& p = *n->profile;
  if (b.kind == PlantInputBinding::Kind::kOutput) {
    const auto* s = std::get_if<model::AnalogOutputSettings>(&p.device);
    if (!s)
      throw ConfigError(
          at + "node " + b.node + " (personality " + p.personality +
          ") has no outputs: output: is for a cia401-analog-output node; object: reads what a master writes");
    if (b.output > s->channels)
      throw ConfigError(at + "node " + b.node + " has outputs 1.." + std::to_string(s->channels) + ", got " +
                        std::to_string(b.output));
    return;
  }
  const OdEntry* e = p.layout->find(b.index, b.sub);
  if (!e)
    throw ConfigError(at + "node " + b.node + " (profile " + p.name + ") has no object " + hex(b.index, 4) + ":" +
                      hex(b.sub, 2).substr(2));
  if (is_variable_size(e->type))
    throw ConfigError(at + "object " + hex(b.index, 4) + ":" + hex(b.sub, 2).substr(2) + " of node " + b.node +
                      " is not a number");
  if (!writable(e->access))
    throw ConfigError(at + "object " + hex(b.index, 4) + ":" + hex(b.sub, 2).substr(2) + " of node " + b.node +
                      " is read-only: a master never writes it");
}

}  // namespace

PlantsConfig parse_plants(const Where& w, const YAML::Node& n) {
  PlantsConfig out;
  if (!n || n.IsNull()) return out;
  if (!n.IsMap()) fail(w, n, "expected a mapping of plant names to plants");
  for (const auto& kv : n) {
    const std::string name = get_string(w, kv.first);
    if (!is_name(name) || name.find('.') != std::string::npos)
      fail(w.child(name), kv.first, "expected a plant name of letters, digits, '_' or '-'");
    out.specs.push_back(parse_plant(w.child(name), name, kv.second, out.bindings));
  }
  out.fingerprint = YAML::Dump(n);
  return out;
}

void check_plants(FleetConfig& fleet, bool bindings) {
  std::unique_ptr<PlantSet> set;
  try {
    set = std::make_unique<PlantSet>(fleet.plants.specs, fleet.seed);
  } catch (const PlantError& e) {
    throw plant_error(e);
  }
  if (bindings)
    for (PlantInputBinding& b : fleet.plants.bindings) check_binding(fleet, b);
  // Every plant term of every profile the nodes use.
  const PlantSetResolver resolver(*set);
  std::set<const model::Profile*> seen;
  for (const NodeConfig& n : fleet.nodes) {
    if (!seen.insert(n.profile.get()).second) continue;
    const ProcessSpec& process = n.profile->physics.process;
    for (const auto& [channel, terms] :
         {std::pair{Channel::Pressure, &process.pressure}, {Channel::Temperature, &process.temperature}})
      for (const TermSpec& t : *terms)
        if (const auto* pt = std::get_if<PlantTermSpec>(&t)) {
          try {
            resolver.resolve(*pt, channel, 0);
          } catch (const std::invalid_argument& e) {
            throw ConfigError(e.what());
          }
        }
  }
}

PlantFaultSpec parse_plant_fault_text(const std::string& source, const std::string& kind,
                                      const std::vector<std::pair<std::string, std::string>>& keys,
                                      const Medium& medium) {
  YAML::Node entry(YAML::NodeType::Map);
  entry["kind"] = kind;
  const Where w{source, ""};
  for (const auto& [key, value] : keys) {
    check_plant_fault_key(w, YAML::Node(key));
    check_yaml_size(value, source + ": " + key, limits::kFaultValueBytes);
    try {
      entry[key] = YAML::Load(value);
    } catch (const YAML::ParserException& ex) {
      throw ConfigError(key + ": " + ex.msg);
    }
  }
  return parse_plant_fault(w, entry, medium);
}

}  // namespace cansim::config
