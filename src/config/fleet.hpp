// Fleet configuration (config/cansimd.yaml): the CAN interfaces with their
// bit rates and the nodes on them, each a profile plus overrides. See
// config/cansimd.yaml for the format. Every error names file, line, key and
// what was expected (ConfigError).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "config/profile.hpp"

namespace cansim::config {

// `bus_model:` of an interface (README "The bus model").
enum class BusModelChoice : std::uint8_t {
  kAuto,   // not given: timed on a virtual bus (vcan), the controller's pacing on real CAN
  kTimed,  // frames wait for the bus: arbitration and frame length at the bit rate
  kIdeal,  // every frame is on the bus the instant its node sends it
};

struct InterfaceConfig {
  std::string name;                 // "vcan0", "can0"
  std::uint32_t bit_rate_kbit = 0;  // 0: ask the kernel, else 250
  BusModelChoice bus_model = BusModelChoice::kAuto;
};

struct NodeConfig {
  std::string key;        // stable identity: "<interface>/<name>/<index>" (storage, reload)
  std::string name;       // the entry's name (default "<profile>-<first node-ID>")
  std::uint32_t index = 0;  // position in a `count:` group
  std::string interface;
  std::uint8_t node_id = 1;             // 1..127 or 0xFF (LSS-unconfigured)
  std::uint32_t bit_rate_kbit = 250;    // the node's own rate
  std::optional<std::uint32_t> serial;  // 0x1018:04: `serial:`, serial_number_base or a count group's default, + index
  std::string record_file;              // `record:` CSV file of the node's physics (empty: none)
  // Shared by the nodes of one entry; a private copy (own layout) when the
  // entry overrides options or vendor parameters.
  std::shared_ptr<Profile> profile;
  std::string fingerprint;  // changes when anything that defines the node changes
  std::string origin;       // "<file>:<line>:<column>: nodes[i]": its entry, for error messages
};

struct FleetConfig {
  std::string file;
  std::uint64_t seed = 1;
  std::vector<InterfaceConfig> interfaces;
  std::vector<NodeConfig> nodes;
  // Distinct profiles (base and variants) in first-use order.
  std::vector<std::shared_ptr<Profile>> profiles;

  const InterfaceConfig* interface(const std::string& name) const;
};

// Where profile names are looked up, in order: as a path (relative to the
// config file's folder, then the cwd), then <dir>/<name>.yaml for each dir.
struct ProfileSearch {
  std::vector<std::string> dirs;
  bool strict = false;  // `cansimd --strict`: every profile loads in strict mode
  bool strict_eds = false;  // `cansimd --strict-eds`: what an EDS reader would repair is an error
  // Set for what a client names (AddNodes): a profile file must lie in one of
  // these folders (symbolic links resolved) or it is refused unopened, and one
  // that does not load is named by its path alone, never by its bytes.
  std::vector<std::string> confined_to;
};
// The default search: <config dir>/profiles, ./profiles, the installed folder.
ProfileSearch default_search(const std::string& config_file, const std::string& installed_dir);
// Resolves a profile reference; empty when not found.
std::string find_profile(const std::string& ref, const std::string& config_dir, const ProfileSearch& search);

// A YAML profile, or a CiA 306 EDS / DCF by its extension .eds / .dcf
// (README, "Device descriptions (EDS/DCF)").
Profile load_any_profile(const std::string& path, bool strict = false, bool strict_eds = false);

FleetConfig load_fleet(const std::string& path, const ProfileSearch& search);
FleetConfig parse_fleet(const std::string& text, const std::string& file, const ProfileSearch& search);
// Nodes added at run time (control API AddNodes): `text` is one node entry,
// a list of entries, or a whole fleet document. Interfaces the fragment does
// not declare take their setting from `running` (else the kernel's / 250).
// Errors name `file`:line:column of the fragment; more entries or nodes than
// config/limits.hpp allows (for one call, or `running` with them) throw TooLarge.
FleetConfig parse_fleet_fragment(const std::string& text, const std::string& file, const ProfileSearch& search,
                                 const FleetConfig& running);
// Appends `extra`'s nodes, interfaces and profiles to `into`. A duplicate
// node key or a node-ID already used on the same interface throws
// ConfigError naming the node; `into` is then unchanged.
void merge_fleet(FleetConfig& into, const FleetConfig& extra);

// `cansimd --profile P [--interface IF] [--node-id N]`: one node.
FleetConfig single_node_fleet(const std::string& profile_ref, const std::string& interface,
                              std::optional<int> node_id, const ProfileSearch& search);

// A fleet configuration (a YAML mapping with `nodes:`) rather than a profile
// or an EDS; false for what cannot be read (the profile loader says why).
bool is_fleet_file(const std::string& path);

// `cansimd --record PATH`: a single node records to PATH; in a fleet, PATH is a
// folder and every node without its own `record:` records to
// PATH/<interface>-<name>-<index>.csv.
void apply_record_option(FleetConfig& fleet, const std::string& path, bool single_node);

}  // namespace cansim::config
