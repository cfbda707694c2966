#include "physics/plant_units.hpp"

#include <array>

#include "physics/units.hpp"

namespace cansim::physics {

namespace {

struct Fixed {
  const char* name;
  QuantityKind kind;
  double factor;
  double offset;
};

// Units whose factor does not depend on the medium. Pressure and temperature
// come from physics/units.hpp (the sensors' table).
constexpr Fixed kFixed[] = {
    {"%", QuantityKind::kFraction, 0.01, 0},
    {"kg/s", QuantityKind::kMassFlow, 1.0, 0},
    {"g/s", QuantityKind::kMassFlow, 1e-3, 0},
    {"kg/min", QuantityKind::kMassFlow, 1.0 / 60, 0},
    {"g/min", QuantityKind::kMassFlow, 1e-3 / 60, 0},
    {"kg/h", QuantityKind::kMassFlow, 1.0 / 3600, 0},
    {"g/h", QuantityKind::kMassFlow, 1e-3 / 3600, 0},
    {"kg", QuantityKind::kMass, 1.0, 0},
    {"g", QuantityKind::kMass, 1e-3, 0},
    {"W", QuantityKind::kPower, 1.0, 0},
    {"kW", QuantityKind::kPower, 1e3, 0},
    {"mW", QuantityKind::kPower, 1e-3, 0},
    {"s", QuantityKind::kTime, 1.0, 0},
    {"ms", QuantityKind::kTime, 1e-3, 0},
    {"us", QuantityKind::kTime, 1e-6, 0},
    {"min", QuantityKind::kTime, 60.0, 0},
    {"h", QuantityKind::kTime, 3600.0, 0},
    {"m3", QuantityKind::kVolume, 1.0, 0},
    {"l", QuantityKind::kVolume, 1e-3, 0},
    {"L", QuantityKind::kVolume, 1e-3, 0},
    {"dm3", QuantityKind::kVolume, 1e-3, 0},
    {"ml", QuantityKind::kVolume, 1e-6, 0},
    {"cm3", QuantityKind::kVolume, 1e-6, 0},
    {"m2", QuantityKind::kArea, 1.0, 0},
    {"cm2", QuantityKind::kArea, 1e-4, 0},
    {"mm2", QuantityKind::kArea, 1e-6, 0},
    {"m", QuantityKind::kLength, 1.0, 0},
    {"cm", QuantityKind::kLength, 1e-2, 0},
    {"mm", QuantityKind::kLength, 1e-3, 0},
    {"kg/m3", QuantityKind::kDensity, 1.0, 0},
    {"g/l", QuantityKind::kDensity, 1.0, 0},
};

// Normal (gas) or plain (liquid) volumetric flows: m3/s per unit.
struct Volumetric {
  const char* name;
  bool gas;
  double m3_per_s;
};
constexpr Volumetric kVolumetric[] = {
    {"Nl/min", true, 1e-3 / 60}, {"Nl/s", true, 1e-3}, {"Nm3/h", true, 1.0 / 3600},
    {"l/min", false, 1e-3 / 60}, {"l/s", false, 1e-3}, {"m3/h", false, 1.0 / 3600},
};

constexpr const char* kKindNames[] = {"number", "fraction", "pressure", "temperature", "mass flow", "mass",
                                      "power",  "time",     "volume",   "area",        "length",    "density"};

}  // namespace

std::string_view kind_name(QuantityKind k) { return kKindNames[std::size_t(k)]; }

double Medium::normal_density() const { return gas ? kNormalPressurePa / (r_specific * kNormalTemperatureK) : density; }

std::optional<Medium> named_medium(std::string_view name) {
  struct Gas {
    const char* name;
    double r, gamma;
  };
  // Specific gas constants R / M (R = 8.314462618 J/(mol K)) and cp / cv at 20 degC.
  static constexpr Gas kGases[] = {{"air", 287.05, 1.400},   {"nitrogen", 296.80, 1.400}, {"oxygen", 259.84, 1.395},
                                   {"argon", 208.13, 1.667}, {"helium", 2077.1, 1.667},   {"hydrogen", 4124.2, 1.405},
                                   {"co2", 188.92, 1.289}};
  for (const Gas& g : kGases)
    if (name == g.name) return Medium{true, g.name, g.r, g.gamma, 0.0};
  if (name == "water") return Medium{false, "water", 0, 0, 998.2};  // at 20 degC
  if (name == "oil") return Medium{false, "oil", 0, 0, 870.0};      // hydraulic oil ISO VG 46
  return std::nullopt;
}

std::string medium_names() { return "air, nitrogen, oxygen, argon, helium, hydrogen, co2, water, oil"; }

std::optional<Unit> find_unit(std::string_view name, const Medium& medium) {
  for (const Fixed& f : kFixed)
    if (name == f.name) return Unit{f.name, f.kind, f.factor, f.offset};
  for (const Volumetric& v : kVolumetric)
    if (name == v.name && v.gas == medium.gas)
      return Unit{v.name, QuantityKind::kMassFlow, v.m3_per_s * medium.normal_density()};
  if (auto p = parse_pressure_unit(name)) return Unit{to_string(*p), QuantityKind::kPressure, pa_per_unit(*p)};
  if (auto t = parse_temperature_unit(name)) {
    const double zero = to_kelvin(0.0, *t);
    return Unit{to_string(*t), QuantityKind::kTemperature, to_kelvin(1.0, *t) - zero, zero};
  }
  return std::nullopt;
}

std::string unit_names(QuantityKind kind) {
  if (kind == QuantityKind::kPressure) return "Pa, hPa, kPa, MPa, bar, mbar, psi, atm, at, mmHg";
  if (kind == QuantityKind::kTemperature) return "K, degC, degF";
  std::string out;
  for (const Fixed& f : kFixed)
    if (f.kind == kind) out += (out.empty() ? "" : ", ") + std::string(f.name);
  if (kind == QuantityKind::kMassFlow)
    for (const Volumetric& v : kVolumetric) out += std::string(", ") + v.name + (v.gas ? " (gas)" : " (liquid)");
  return out;
}

Unit display_unit(QuantityKind kind) {
  switch (kind) {
    case QuantityKind::kNumber: return {"", kind, 1.0};
    case QuantityKind::kFraction: return {"%", kind, 0.01};
    case QuantityKind::kPressure: return {"bar", kind, kPaPerBar};
    case QuantityKind::kTemperature: return {"degC", kind, 1.0, kZeroCelsiusK};
    case QuantityKind::kMassFlow: return {"g/s", kind, 1e-3};
    case QuantityKind::kMass: return {"g", kind, 1e-3};
    case QuantityKind::kPower: return {"W", kind, 1.0};
    case QuantityKind::kTime: return {"s", kind, 1.0};
    case QuantityKind::kVolume: return {"l", kind, 1e-3};
    case QuantityKind::kArea: return {"mm2", kind, 1e-6};
    case QuantityKind::kLength: return {"mm", kind, 1e-3};
    case QuantityKind::kDensity: return {"kg/m3", kind, 1.0};
  }
  return {"", kind, 1.0};
}

double to_unit(double si, const Unit& u) { return (si - u.offset) / u.factor; }
double from_unit(double value, const Unit& u) { return value * u.factor + u.offset; }

}  // namespace cansim::physics
