// CiA 303-2 physical-unit codes (0x6131) and the exact conversions between a
// node's current unit and the SI values of the physics layer (Pa, K).
//
// Code layout (CiA 303-2): bits 31-24 = prefix, a signed power of ten
// (0x03 kilo, 0xFD milli), bits 23-16 = unit code, bits 15-0 = 0 (a vendor
// may put a denominator there; the SMC reports 0x004E0100 "bar").
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "physics/channel.hpp"

namespace cansim::model {

// CiA 303-2 unit codes (bits 23-16) used by pressure / temperature sensors.
namespace unit_code {
constexpr std::uint8_t kKelvin = 0x05;
constexpr std::uint8_t kPascal = 0x22;
constexpr std::uint8_t kCelsius = 0x2D;
constexpr std::uint8_t kBar = 0x4E;
constexpr std::uint8_t kPsi = 0xAB;
constexpr std::uint8_t kFahrenheit = 0xAC;
}  // namespace unit_code

constexpr std::uint32_t make_unit(std::int8_t prefix, std::uint8_t code) {
  return (std::uint32_t(std::uint8_t(prefix)) << 24) | (std::uint32_t(code) << 16);
}
constexpr std::int8_t unit_prefix(std::uint32_t unit) { return std::int8_t(unit >> 24); }

// value_in_unit = (si - si_zero) / si_per_unit.
struct UnitScale {
  physics::Channel kind = physics::Channel::Pressure;  // the quantity it measures
  double si_per_unit = 1.0;                            // Pa or K per one unit (prefix included)
  double si_zero = 0.0;                                // SI value of 0 units (273.15 K for degC)
  // As the control API names it ("bar", "mbar", "kPa", "degC", ...); "" for a
  // code without a name of its own (a rare prefix, a user-scaled unit).
  std::string_view name;

  double from_si(double si) const { return (si - si_zero) / si_per_unit; }
  double to_si(double v) const { return v * si_per_unit + si_zero; }
  // Differences (offset, delta, hysteresis): no zero shift.
  double delta_from_si(double si) const { return si / si_per_unit; }
  double delta_to_si(double v) const { return v * si_per_unit; }
};

// The scale of a CiA 303-2 code with a built-in unit (Pa, bar, psi, degC,
// degF, K, with any prefix; bits 15-0 ignored). nullopt for other codes.
std::optional<UnitScale> builtin_unit(std::uint32_t code);

// A unit by name as written in profiles: "bar", "dbar", "cbar", "mbar", "kPa",
// "MPa", "hPa", "Pa", "psi", "dpsi", "cpsi", "mpsi", "atm", "at", "mmHg", "degC", "degF", "K" (physics/units.hpp
// spellings). `code` receives the CiA 303-2 code when the unit has a built-in
// one (0 for atm / at / mmHg, whose codes a profile must give).
std::optional<UnitScale> named_unit(std::string_view name, std::uint32_t* code = nullptr);

// Converts a value between units of the same kind (absolute or difference).
inline double convert(double v, const UnitScale& from, const UnitScale& to, bool difference) {
  return difference ? to.delta_from_si(from.delta_to_si(v)) : to.from_si(from.to_si(v));
}

}  // namespace cansim::model
