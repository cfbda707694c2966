// A node profile as one typed model: identity, bit rate, options (quirks),
// the object dictionary, the CiA 404 chain bound to it, the personality's
// settings and the physics. Filled by a loader (config/: YAML profiles;
// EDS / DCF files), checked there against what the personality declares it
// needs, and read by personalities and the daemon, which never see the file.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/node_options.hpp"
#include "core/od.hpp"
#include "model/cia404_profile.hpp"
#include "model/device_settings.hpp"
#include "physics/fault.hpp"
#include "physics/process.hpp"
#include "physics/sensor.hpp"

namespace cansim::model {

// The physics of every node of the profile (`physics:`, `sensor:`, `faults:`).
struct PhysicsConfig {
  physics::ProcessSpec process;
  physics::SensorSpec sensor;
  std::vector<physics::FaultSpec> faults;
};

// One deviation of faithful mode from CiA (`cansimd --quirks`).
struct Quirk {
  std::string name;       // option, "object 0x1003:00", "cia404.bad_unit_abort"
  std::string reference;  // the manual's page / table
  std::string faithful;   // value in faithful mode
  std::string strict;     // value in strict mode
};

struct Profile {
  std::string file;  // where it was loaded from
  std::string name;
  std::string description;
  std::string personality = "generic";  // behaviour module (matches `device`)
  std::uint8_t node_id = 1;             // default node-ID (0xFF = LSS-unconfigured)
  std::uint32_t bit_rate_kbit = 250;    // default bit rate
  std::shared_ptr<OdLayout> layout;     // finalized; the chain's hooks are set
  std::shared_ptr<NodeOptions> options;
  // The CiA 404 chain, bound to `layout` (null only before a loader binds it).
  std::shared_ptr<const Cia404Profile> cia404;
  IdentitySettings identity;
  DeviceSettings device;
  PhysicsConfig physics;
  // `emcy:` what the manual says each EMCY error code this device sends means
  // (cansimctl monitor, the DBC's value table); codes not listed mean what
  // CiA 301 / 404 say.
  std::map<std::uint16_t, std::string> emcy_codes;

  // Strict mode (config/strict_mode.hpp): the profile as written, the
  // entries strict mode replaces or adds, the manual reference per deviation.
  bool strict = false;
  std::shared_ptr<const NodeOptions> faithful_options;
  std::shared_ptr<const OdLayout> faithful_layout;
  std::vector<OdEntry> strict_objects;
  std::vector<std::pair<std::string, std::string>> quirks;  // name -> manual reference
  bool quirks_checked = false;                              // has a `quirks:` map (checked against the deviations)
  std::vector<Quirk> setting_quirks;                        // chain / device settings strict mode changes

  // What the loader repaired in the file, "file:line: ..." (EDS / DCF:
  // config/eds_reader.hpp); `cansimd --check` and the start log show them.
  std::vector<std::string> warnings;
};

}  // namespace cansim::model
