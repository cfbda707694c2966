// Personality registry: turns a profile's `personality:` name into the
// Application that gives each node its vendor behaviour and measurements.
//
// A personality is two functions (see generic.hpp): `prepare` validates its
// part of the `vendor:` section once per profile and `make` builds one node's
// Application. The shared part — the CiA 404 chain settings (`vendor:
// cia404:`), identity settings and the physics sections — is parsed here for
// every personality into a PreparedProfile.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <memory>
#include <string>

#include "config/physics_config.hpp"
#include "config/profile.hpp"
#include "config/strict_mode.hpp"
#include "core/application.hpp"
#include "personalities/cia404.hpp"

namespace cansim::personalities {

// What distinguishes one node of a fleet from another built from the same profile.
struct NodeContext {
  std::uint64_t fleet_seed = 1;   // physics randomness: fleet seed + node key
  std::uint32_t index = 0;        // position in a `count:` group (serial-number offset)
  std::string key;                // stable name, e.g. "vcan0/dps-3"
  std::string record_file;        // CSV recording of truth and readings (empty: none)
};

// Parsed once per profile, shared by its nodes (Profile::prepared).
struct PreparedProfile {
  std::shared_ptr<const Cia404Profile> cia404;
  config::PhysicsConfig physics;
  IdentitySettings identity;
  std::shared_ptr<const void> device;  // a device personality's own parsed data
  // Chain / device settings strict mode changes (faithful vs strict value, reference).
  std::vector<config::Quirk> setting_quirks;
};

// Checks the profile's personality name, vendor, physics, sensor and faults
// sections, and marks the OD entries the personality needs hooks on. Called
// once per profile, before nodes are built. Throws config::ConfigError.
void prepare_profile(config::Profile& profile);

// The profile's deviations from CiA (`cansimd --quirks`): options and
// objects, then chain / device settings once the profile is prepared.
std::vector<config::Quirk> quirk_inventory(const config::Profile& profile);

// One Application per node (nullptr: plain CiA 301 node without measurements).
std::unique_ptr<Application> make_application(const config::Profile& profile, const NodeContext& ctx);

// ---- helpers for personalities
// The numeric objects a personality's behaviour reads or writes. Throws
// config::ConfigError naming the profile's `objects:` line and what the
// personality needs the first missing one for.
struct RequiredObject {
  std::uint16_t index;
  std::uint8_t first_sub, last_sub;
  const char* purpose;
};
void require_objects(const config::Profile& profile, std::initializer_list<RequiredObject> objects);
// Fails unless the CiA 404 chain has at least `count` channels.
void require_channels(const config::Profile& profile, const PreparedProfile& prepared, std::size_t count,
                      const char* purpose);
// A device personality's own parsed data (PreparedProfile::device).
template <class Settings>
const Settings& device_settings(const PreparedProfile& prepared) {
  return *std::static_pointer_cast<const Settings>(prepared.device);
}
// The node's seed: fleet seed + node key (+ index when the key is empty).
std::uint64_t node_seed(const NodeContext& ctx);
// The node's physics (process + sensor + faults) from the prepared profile;
// opens ctx.record_file when set (throws std::runtime_error when it cannot).
std::unique_ptr<SensorSource> make_sensor_source(const PreparedProfile& prepared, const NodeContext& ctx);

}  // namespace cansim::personalities
