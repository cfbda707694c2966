// Physical units for the physics layer.
//
// Internally the physics layer works exclusively in SI: pressure in pascal (Pa),
// temperature in kelvin (K), time in seconds (double) or microseconds (TimeUs).
// The helpers below convert user-facing values (YAML, CSV, SDO units) exactly.
//
// Conversion factors (exact by definition):
//   1 bar  = 100000 Pa            1 mbar = 100 Pa        1 hPa = 100 Pa
//   1 kPa  = 1000 Pa              1 MPa  = 1e6 Pa
//   1 psi  = 0.45359237 kg * 9.80665 m/s^2 / (0.0254 m)^2 = 6894.757293168361 Pa
//   1 atm  = 101325 Pa            1 at (kgf/cm^2) = 98066.5 Pa
//   1 mmHg = 133.322387415 Pa     (conventional millimetre of mercury)
//   K = degC + 273.15             K = (degF - 32) * 5/9 + 273.15
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace cansim::physics {

enum class PressureUnit : std::uint8_t { Pa, hPa, kPa, MPa, bar, mbar, psi, atm, at, mmHg };
enum class TemperatureUnit : std::uint8_t { K, degC, degF };

inline constexpr double kPaPerPsi = 6894.757293168361;
inline constexpr double kPaPerBar = 1.0e5;
inline constexpr double kZeroCelsiusK = 273.15;

// Pascal per one unit of `u` (exact constants, see file header).
constexpr double pa_per_unit(PressureUnit u) {
  switch (u) {
    case PressureUnit::Pa: return 1.0;
    case PressureUnit::hPa: return 100.0;
    case PressureUnit::kPa: return 1000.0;
    case PressureUnit::MPa: return 1.0e6;
    case PressureUnit::bar: return kPaPerBar;
    case PressureUnit::mbar: return 100.0;
    case PressureUnit::psi: return kPaPerPsi;
    case PressureUnit::atm: return 101325.0;
    case PressureUnit::at: return 98066.5;
    case PressureUnit::mmHg: return 133.322387415;
  }
  return 1.0;
}

// Absolute pressure (or pressure difference, same factor) to / from pascal.
constexpr double to_pa(double v, PressureUnit u) { return v * pa_per_unit(u); }
constexpr double from_pa(double pa, PressureUnit u) { return pa / pa_per_unit(u); }

// Absolute temperature to / from kelvin.
constexpr double to_kelvin(double v, TemperatureUnit u) {
  switch (u) {
    case TemperatureUnit::K: return v;
    case TemperatureUnit::degC: return v + kZeroCelsiusK;
    case TemperatureUnit::degF: return (v - 32.0) * 5.0 / 9.0 + kZeroCelsiusK;
  }
  return v;
}
constexpr double from_kelvin(double k, TemperatureUnit u) {
  switch (u) {
    case TemperatureUnit::K: return k;
    case TemperatureUnit::degC: return k - kZeroCelsiusK;
    case TemperatureUnit::degF: return (k - kZeroCelsiusK) * 9.0 / 5.0 + 32.0;
  }
  return k;
}

// Temperature *differences* (amplitudes, offsets, rates): no zero shift.
// 1 degF difference = 5/9 K.
constexpr double delta_to_kelvin(double v, TemperatureUnit u) { return u == TemperatureUnit::degF ? v * 5.0 / 9.0 : v; }
constexpr double delta_from_kelvin(double k, TemperatureUnit u) {
  return u == TemperatureUnit::degF ? k * 9.0 / 5.0 : k;
}

// Parse unit names. Accepted (case-sensitive where case carries meaning):
//   pressure:    "Pa" "pa" "hPa" "hpa" "kPa" "kpa" "MPa" "bar" "mbar" "psi" "PSI"
//                "atm" "at" "mmHg" "mmhg" "torr"(=mmHg, within 1e-7)
//   temperature: "K" "kelvin" "degC" "°C" "C" "celsius" "degF" "°F" "F" "fahrenheit"
// Returns nullopt for anything else (note: "mPa" is millipascal and rejected).
std::optional<PressureUnit> parse_pressure_unit(std::string_view s);
std::optional<TemperatureUnit> parse_temperature_unit(std::string_view s);
std::string_view to_string(PressureUnit u);
std::string_view to_string(TemperatureUnit u);

// Parse "<number> <unit>" (space optional, e.g. "2.5 bar", "25degC", "-40 °C",
// "1e5 Pa"). A bare number without unit is interpreted in `default_unit`.
// Returns the value in Pa / K, nullopt on syntax error or unknown unit.
std::optional<double> parse_pressure(std::string_view s, PressureUnit default_unit = PressureUnit::Pa);
std::optional<double> parse_temperature(std::string_view s, TemperatureUnit default_unit = TemperatureUnit::K);

}  // namespace cansim::physics
