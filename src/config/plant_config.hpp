// YAML -> plants: a fleet's `plants:` section (docs/plants.md) into the
// engine's specs (physics/plant.hpp) and the bindings of the inputs that
// read the bus or a node (the daemon wires them). Every error names
// file:line:column: key.path, at --check and at start alike.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "config/yaml_util.hpp"
#include "core/can_signal.hpp"
#include "physics/plant.hpp"

namespace cansim::config {

struct FleetConfig;

// Where a plant input's values come from outside the plant: a signal in
// frames on an interface, an object a master writes into a simulated node
// (SDO or RPDO), or a node's output (the actuator's position as it moves).
struct PlantInputBinding {
  enum class Kind : std::uint8_t { kFrame, kObject, kOutput };
  Kind kind = Kind::kFrame;
  std::string plant;
  std::string input;
  std::size_t input_index = 0;
  std::string interface;    // kFrame
  CanSignal signal;         // kFrame: raw x scale + offset is in the input's unit
  std::string node;         // kObject, kOutput: the node as written (name, key, name/INDEX)
  std::string node_key;     // resolved against the fleet (check_plants)
  std::uint16_t index = 0;  // kObject
  std::uint8_t sub = 0;
  unsigned output = 1;               // kOutput: 1-based
  double scale = 1.0, offset = 0.0;  // kObject, kOutput: raw x scale + offset is in the input's unit
  physics::Unit unit;                // the input's unit: its value to SI
  std::string origin;
};

struct PlantsConfig {
  std::vector<physics::PlantSpec> specs;
  std::vector<PlantInputBinding> bindings;
  std::string fingerprint;  // changes when the section does
  bool empty() const { return specs.empty(); }
};

PlantsConfig parse_plants(const Where& w, const YAML::Node& plants);

// The fleet's plants checked against what the fleet has: the engine builds
// every plant (algebraic loops, impossible parameters), every plant term of
// a node's physics names a variable that exists and measures what the
// channel does, every binding names a declared interface, a node of the
// fleet and an object it has (numeric, writable by a master) or an output
// its personality drives. Resolves the bindings' node keys. Throws
// ConfigError at the place of the first fault. `bindings` false: only the
// nodes' plant terms (nodes added at run time to a running fleet).
void check_plants(FleetConfig& fleet, bool bindings = true);

// A plant fault as ArmFault gives it (kind and its keys' YAML values,
// `target` among them), parsed like an entry of a plant's `faults:`.
physics::PlantFaultSpec parse_plant_fault_text(const std::string& source, const std::string& kind,
                                               const std::vector<std::pair<std::string, std::string>>& keys,
                                               const physics::Medium& medium);

}  // namespace cansim::config
