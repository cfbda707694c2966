// Quantities of the plant engine (physics/plant.hpp): what a plant variable
// or input measures, the units a loader accepts for it, the unit it is shown
// in, and the medium a plant's flow laws use.
//
// Decisions:
//  * Inside a plant every value is SI: Pa (absolute), K, kg/s (mass flow),
//    kg, W, s, m3, m2, a fraction 0..1 for openings and speeds ("40 %" =
//    0.4). Flows are mass flows everywhere, so one volume can sum what a pump,
//    a valve and a leak move whatever the medium.
//  * Normal volumetric gas flows (Nl/min, Nm3/h) are converted with the
//    density of the plant's own gas at normal conditions (0 degC, 1.01325
//    bar, DIN 1343); liquid volumetric flows (l/min, m3/h) with the plant's
//    liquid density. So a unit's factor may depend on the medium.
//  * Each kind has one display unit (bar, degC, g/s, g, %, ...): what the
//    control API, cansimctl and the Python client show, each value with the
//    unit it is in.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace cansim::physics {

enum class QuantityKind : std::uint8_t {
  kNumber,       // dimensionless
  kFraction,     // 0..1, shown in %
  kPressure,     // Pa (absolute)
  kTemperature,  // K (absolute)
  kMassFlow,     // kg/s
  kMass,         // kg
  kPower,        // W
  kTime,         // s
  kVolume,       // m3
  kArea,         // m2
  kLength,       // m
  kDensity,      // kg/m3
};

// "pressure", "mass flow", ... for messages.
std::string_view kind_name(QuantityKind k);

// The medium of a plant: an ideal gas, or an incompressible liquid.
struct Medium {
  bool gas = true;
  std::string name = "air";
  double r_specific = 287.05;  // J/(kg K), gas
  double gamma = 1.4;          // heat capacity ratio cp/cv, gas
  double density = 1000.0;     // kg/m3, liquid
  // Density at normal conditions (gas: DIN 1343, 273.15 K and 101325 Pa).
  double normal_density() const;
};

inline constexpr double kNormalPressurePa = 101325.0;
inline constexpr double kNormalTemperatureK = 273.15;
inline constexpr double kAmbientPressurePa = 101325.0;  // default downstream of vents and leaks
inline constexpr double kRoomTemperatureK = 293.15;     // default gas temperature

// Gases and liquids by name (air, nitrogen, oxygen, argon, helium, hydrogen,
// co2; water, oil); nullopt for another name.
std::optional<Medium> named_medium(std::string_view name);
// "air, nitrogen, ..." for messages.
std::string medium_names();

// One unit: si = value * factor + offset.
struct Unit {
  std::string_view name;
  QuantityKind kind;
  double factor;
  double offset = 0.0;
};

// The unit `name` in the plant's `medium` (volumetric flows depend on it);
// nullopt for an unknown name.
std::optional<Unit> find_unit(std::string_view name, const Medium& medium);
// The units of a kind, "bar, mbar, Pa, ..." for messages.
std::string unit_names(QuantityKind kind);

// The unit a kind is shown in (bar, degC, g/s, g, W, %, s, l, mm2, mm,
// kg/m3; "" for plain numbers) and the conversions.
Unit display_unit(QuantityKind kind);
double to_unit(double si, const Unit& u);
double from_unit(double value, const Unit& u);

}  // namespace cansim::physics
