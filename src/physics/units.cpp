#include "physics/units.hpp"

#include <charconv>

namespace cansim::physics {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r' || s.back() == '\n'))
    s.remove_suffix(1);
  return s;
}

// Splits "<number><space?><unit>" into number and unit text.
bool split_quantity(std::string_view s, double& value, std::string_view& unit) {
  s = trim(s);
  if (s.empty()) return false;
  const char* first = s.data();
  const char* last = s.data() + s.size();
  if (*first == '+') ++first;  // from_chars rejects a leading '+'
  auto [ptr, ec] = std::from_chars(first, last, value);
  if (ec != std::errc{}) return false;
  unit = trim(std::string_view(ptr, std::size_t(last - ptr)));
  return true;
}

}  // namespace

std::optional<PressureUnit> parse_pressure_unit(std::string_view s) {
  s = trim(s);
  if (s == "Pa" || s == "pa") return PressureUnit::Pa;
  if (s == "hPa" || s == "hpa") return PressureUnit::hPa;
  if (s == "kPa" || s == "kpa") return PressureUnit::kPa;
  if (s == "MPa") return PressureUnit::MPa;
  if (s == "bar") return PressureUnit::bar;
  if (s == "mbar") return PressureUnit::mbar;
  if (s == "psi" || s == "PSI") return PressureUnit::psi;
  if (s == "atm") return PressureUnit::atm;
  if (s == "at") return PressureUnit::at;
  if (s == "mmHg" || s == "mmhg" || s == "torr" || s == "Torr") return PressureUnit::mmHg;
  return std::nullopt;
}

std::optional<TemperatureUnit> parse_temperature_unit(std::string_view s) {
  s = trim(s);
  if (s == "K" || s == "kelvin") return TemperatureUnit::K;
  if (s == "degC" ||
      s == "\xC2\xB0"
           "C" ||
      s == "C" || s == "celsius" || s == "Celsius")
    return TemperatureUnit::degC;
  if (s == "degF" ||
      s == "\xC2\xB0"
           "F" ||
      s == "F" || s == "fahrenheit" || s == "Fahrenheit")
    return TemperatureUnit::degF;
  return std::nullopt;
}

std::string_view to_string(PressureUnit u) {
  switch (u) {
    case PressureUnit::Pa: return "Pa";
    case PressureUnit::hPa: return "hPa";
    case PressureUnit::kPa: return "kPa";
    case PressureUnit::MPa: return "MPa";
    case PressureUnit::bar: return "bar";
    case PressureUnit::mbar: return "mbar";
    case PressureUnit::psi: return "psi";
    case PressureUnit::atm: return "atm";
    case PressureUnit::at: return "at";
    case PressureUnit::mmHg: return "mmHg";
  }
  return "?";
}

std::string_view to_string(TemperatureUnit u) {
  switch (u) {
    case TemperatureUnit::K: return "K";
    case TemperatureUnit::degC: return "degC";
    case TemperatureUnit::degF: return "degF";
  }
  return "?";
}

std::optional<double> parse_pressure(std::string_view s, PressureUnit default_unit) {
  double v = 0;
  std::string_view unit;
  if (!split_quantity(s, v, unit)) return std::nullopt;
  PressureUnit u = default_unit;
  if (!unit.empty()) {
    auto pu = parse_pressure_unit(unit);
    if (!pu) return std::nullopt;
    u = *pu;
  }
  return to_pa(v, u);
}

std::optional<double> parse_temperature(std::string_view s, TemperatureUnit default_unit) {
  double v = 0;
  std::string_view unit;
  if (!split_quantity(s, v, unit)) return std::nullopt;
  TemperatureUnit u = default_unit;
  if (!unit.empty()) {
    auto tu = parse_temperature_unit(unit);
    if (!tu) return std::nullopt;
    u = *tu;
  }
  return to_kelvin(v, u);
}

}  // namespace cansim::physics
