#include "model/units.hpp"

#include <string>

#include "physics/quantize.hpp"
#include "physics/units.hpp"

namespace cansim::model {

namespace {

struct Named {
  std::string_view name;
  std::uint32_t code;
};
// The first spelling of a code is its name.
constexpr Named kNamed[] = {
    {"Pa", make_unit(0, unit_code::kPascal)},       {"hPa", make_unit(2, unit_code::kPascal)},
    {"kPa", make_unit(3, unit_code::kPascal)},      {"MPa", make_unit(6, unit_code::kPascal)},
    {"bar", make_unit(0, unit_code::kBar)},         {"mbar", make_unit(-3, unit_code::kBar)},
    {"dbar", make_unit(-1, unit_code::kBar)},       {"cbar", make_unit(-2, unit_code::kBar)},
    {"dpsi", make_unit(-1, unit_code::kPsi)},       {"cpsi", make_unit(-2, unit_code::kPsi)},
    {"mpsi", make_unit(-3, unit_code::kPsi)},       {"psi", make_unit(0, unit_code::kPsi)},
    {"degC", make_unit(0, unit_code::kCelsius)},    {"°C", make_unit(0, unit_code::kCelsius)},
    {"degF", make_unit(0, unit_code::kFahrenheit)}, {"°F", make_unit(0, unit_code::kFahrenheit)},
    {"K", make_unit(0, unit_code::kKelvin)},
};

std::string_view name_of(std::uint32_t code) {
  for (const Named& n : kNamed)
    if (n.code == (code & 0xFFFF0000u)) return n.name;
  return {};
}

UnitScale pressure(double pa_per_unit, std::string_view name = {}) {
  return {physics::Channel::Pressure, pa_per_unit, 0.0, name};
}

UnitScale temperature(physics::TemperatureUnit u) {
  double zero = physics::to_kelvin(0.0, u);
  double per = physics::delta_to_kelvin(1.0, u);
  return {physics::Channel::Temperature, per, zero, physics::to_string(u)};
}

std::optional<UnitScale> builtin_scale(std::uint32_t code) {
  const int prefix = unit_prefix(code);
  if (prefix < -18 || prefix > 18) return std::nullopt;
  const double p10 = physics::pow10(prefix);
  switch (std::uint8_t(code >> 16)) {
    case unit_code::kPascal: return pressure(p10);
    case unit_code::kBar: return pressure(physics::kPaPerBar * p10);
    case unit_code::kPsi: return pressure(physics::kPaPerPsi * p10);
    default: break;
  }
  // Temperatures take no prefix (a "milli-degC" would be a vendor invention).
  if (prefix != 0) return std::nullopt;
  switch (std::uint8_t(code >> 16)) {
    case unit_code::kCelsius: return temperature(physics::TemperatureUnit::degC);
    case unit_code::kFahrenheit: return temperature(physics::TemperatureUnit::degF);
    case unit_code::kKelvin: return temperature(physics::TemperatureUnit::K);
    default: return std::nullopt;
  }
}

}  // namespace

std::optional<UnitScale> builtin_unit(std::uint32_t code) {
  std::optional<UnitScale> s = builtin_scale(code);
  if (s) s->name = name_of(code);
  return s;
}

std::optional<UnitScale> named_unit(std::string_view name, std::uint32_t* code) {
  for (const Named& n : kNamed) {
    if (n.name == name) {
      if (code) *code = n.code;
      return builtin_unit(n.code);
    }
  }
  if (code) *code = 0;
  if (auto p = physics::parse_pressure_unit(name)) return pressure(physics::pa_per_unit(*p), physics::to_string(*p));
  if (auto t = physics::parse_temperature_unit(name)) return temperature(*t);
  return std::nullopt;
}

}  // namespace cansim::model
