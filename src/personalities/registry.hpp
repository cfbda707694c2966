// Personality registry: turns a typed profile (model::Profile, its `device`
// settings naming the behaviour) into the Application that gives each node
// its vendor behaviour and measurements. Profiles come from a loader
// (config/), which checked them against personalities/catalog.hpp.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/application.hpp"
#include "model/profile.hpp"
#include "personalities/catalog.hpp"
#include "personalities/cia404.hpp"
#include "personalities/measurement_control.hpp"

namespace cansim::personalities {

// What distinguishes one node of a fleet from another built from the same profile.
struct NodeContext {
  std::uint64_t fleet_seed = 1;   // physics randomness: fleet seed + node key
  std::uint32_t index = 0;        // position in a `count:` group (serial-number offset)
  std::string key;                // stable name, e.g. "vcan0/dps-3"
  std::string record_file;        // CSV recording of truth and readings (empty: none)
  std::string state_dir = {};     // the daemon's stored parameters: never recorded into
};

// One Application per node, by the profile's device settings.
std::unique_ptr<Application> make_application(const model::Profile& profile, const NodeContext& ctx);

// ---- helpers for personalities
// The node's seed: fleet seed + node key (+ index when the key is empty).
std::uint64_t node_seed(const NodeContext& ctx);
// The node's physics (process + sensor + faults) from the profile; opens
// ctx.record_file when set (throws std::runtime_error when it cannot).
std::unique_ptr<SensorSource> make_sensor_source(const model::Profile& profile, const NodeContext& ctx);

}  // namespace cansim::personalities
