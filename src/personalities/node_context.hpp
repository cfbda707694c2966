// What a personality is built from besides its profile: the node's place in
// the fleet (NodeContext) and the node's physics, made from the profile for
// it (make_sensor_source). Vendor headers include this, never the registry
// (registry.hpp): the registry includes the vendors, so an arrow back up
// would make every vendor depend on every other (scripts/layers --check).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "model/profile.hpp"
#include "personalities/sensor_source.hpp"
#include "physics/plant.hpp"

namespace cansim::personalities {

// What distinguishes one node of a fleet from another built from the same profile.
struct NodeContext {
  std::uint64_t fleet_seed = 1;  // physics randomness: fleet seed + node key
  std::uint32_t index = 0;       // position in a `count:` group (serial-number offset)
  std::string key;               // stable name, e.g. "vcan0/dps-3"
  std::string record_file;       // CSV recording of truth and readings (empty: none)
  std::string state_dir = {};    // the daemon's stored parameters: never recorded into
  // The fleet's plants, for a physics that reads one (`{plant: ...}`); null:
  // none (such a profile is refused). Outlives the node.
  const physics::PlantResolver* plants = nullptr;
};

// The node's seed: fleet seed + node key (+ index when the key is empty).
std::uint64_t node_seed(const NodeContext& ctx);
// The node's physics (process + sensor + faults) from the profile; opens
// ctx.record_file when set (throws std::runtime_error when it cannot).
std::unique_ptr<SensorSource> make_sensor_source(const model::Profile& profile, const NodeContext& ctx);

}  // namespace cansim::personalities
