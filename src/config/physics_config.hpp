// YAML -> physics specs: a profile's `physics:` (process model), `sensor:`
// (measurement chain) and `faults:` (scheduled measurement faults) sections.
// Format: docs/profile-physics.md. Quantities are "<number> <unit>" strings
// ("5 bar", "20 degC", "10 ms", "1 kHz"); a bare number is SI (Pa, K, s, Hz).
// Every error names file:line:column: key.path.
#pragma once

#include <cstdint>
#include <vector>

#include "config/profile.hpp"
#include "config/yaml_util.hpp"
#include "physics/fault.hpp"
#include "physics/plant_units.hpp"
#include "physics/process.hpp"
#include "physics/sensor.hpp"

namespace cansim::config {

// What a YAML quantity measures; decides the accepted units.
enum class Dim : std::uint8_t {
  kPressure,          // Pa, bar, psi, ...
  kTemperature,       // absolute: degC, degF, K
  kTemperatureDelta,  // difference: K, degC (= K), degF (= 5/9 K)
  kTime,              // s, ms, us, min, h
  kFrequency,         // Hz, kHz, rpm
  kNumber,            // plain number, or "<n> %" (= n / 100)
  // plant quantities (physics/plant_units.hpp; volumetric flows in the plant's medium)
  kMassFlow,  // kg/s, g/s, kg/h, Nl/min (gas), l/min (liquid), ...
  kMass,      // kg, g
  kPower,     // W, kW
  kVolume,    // m3, l, ml, cm3
  kArea,      // m2, cm2, mm2
  kLength,    // m, cm, mm
  kDensity,   // kg/m3, g/l
};

// Parses one quantity into SI. `medium` (null: air) converts volumetric flows.
double get_quantity(const Where& w, const YAML::Node& n, Dim dim, const physics::Medium* medium = nullptr);

using model::PhysicsConfig;

// The defaults used for sections a profile leaves out: a 0..10 bar /
// -40..125 degC sensor; pressure drifting around 5 bar, temperature
// swinging slowly between 20 and 25 degC.
physics::ProcessSpec default_process();
physics::SensorSpec default_sensor();

physics::ProcessSpec parse_process(const Where& w, const YAML::Node& physics);
// One channel's model as a profile's `physics: pressure:` (or `temperature:`)
// accepts it: a term list, one term or a constant ("5 bar"); validated.
std::vector<physics::TermSpec> parse_channel_model(const Where& w, const YAML::Node& model, physics::Channel channel);
// `base` supplies every value a channel map does not set.
physics::SensorSpec parse_sensor(const Where& w, const YAML::Node& sensor, const physics::SensorSpec& base);
std::vector<physics::FaultSpec> parse_faults(const Where& w, const YAML::Node& faults);
// One entry of `faults:` (a mapping with `kind` and its keys). Plant kinds
// (leak, blocked, valve_stuck, input_lost) are refused: they go on a plant.
physics::FaultSpec parse_fault(const Where& w, const YAML::Node& fault);
// The scheduling keys of a fault entry (at, after, duration, period, count)
// into `f.timing` (f.kind set: a zero duration is only a power cycle's).
void parse_fault_timing(const Where& w, const YAML::Node& m, physics::FaultSpec& f);
// A list of process terms as a channel's `physics:` takes it, in `level`
// (first term) and `delta` (the others) with `medium` for flows: a plant's
// time input (docs/plants.md).
std::vector<physics::TermSpec> parse_terms(const Where& w, const YAML::Node& n, Dim level, Dim delta,
                                           const physics::Medium* medium);
// "file:line:column: key.path" of a node, as errors begin.
std::string origin_of(const Where& w, const YAML::Node& n);

// The same parsers on text, for the control API: a channel model as YAML
// text, and a fault from its kind and its keys' values (each a YAML
// scalar, "2 s", "0.5 bar"). Errors (syntax included) throw ConfigError
// naming `source` ("<SetModel>:1:5: ...").
std::vector<physics::TermSpec> parse_channel_model_text(const std::string& source, const std::string& channel_name,
                                                        const std::string& text, physics::Channel channel);
physics::FaultSpec parse_fault_text(const std::string& source, const std::string& kind,
                                    const std::vector<std::pair<std::string, std::string>>& keys);

// All three sections of a profile document (defaults for the missing ones).
PhysicsConfig parse_physics_config(const std::string& file, const YAML::Node& root);

}  // namespace cansim::config
