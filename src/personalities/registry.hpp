// Personality registry: turns a profile's `personality:` name into the
// Application that gives each node its vendor behaviour and measurements.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "config/profile.hpp"
#include "core/application.hpp"

namespace cansim::personalities {

// What distinguishes one node of a fleet from another built from the same profile.
struct NodeContext {
  std::uint64_t fleet_seed = 1;   // physics randomness: fleet seed + node key
  std::uint32_t index = 0;        // position in a `count:` group (serial-number offset)
  std::string key;                // stable name, e.g. "vcan0/dps-3"
};

// Checks the profile's personality name and vendor section, and marks the OD
// entries the personality needs hooks on. Called once per profile, before
// nodes are built. Throws config::ConfigError.
void prepare_profile(config::Profile& profile);

// One Application per node (nullptr: plain CiA 301 node without measurements).
std::unique_ptr<Application> make_application(const config::Profile& profile, const NodeContext& ctx);

}  // namespace cansim::personalities
