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
#include "physics/process.hpp"
#include "physics/sensor.hpp"

namespace cansim::config {

// What a YAML quantity measures; decides the accepted units.
enum class Dim : std::uint8_t {
  kPressure,         // Pa, bar, psi, ...
  kTemperature,      // absolute: degC, degF, K
  kTemperatureDelta, // difference: K, degC (= K), degF (= 5/9 K)
  kTime,             // s, ms, us, min, h
  kFrequency,        // Hz, kHz, rpm
  kNumber,           // plain number, or "<n> %" (= n / 100)
};

// Parses one quantity into SI.
double get_quantity(const Where& w, const YAML::Node& n, Dim dim);

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
// One entry of `faults:` (a mapping with `kind` and its keys).
physics::FaultSpec parse_fault(const Where& w, const YAML::Node& fault);

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
