// Fleet configuration (config/cansimd.yaml): the CAN interfaces with their
// bit rates and the nodes on them, each a profile plus overrides. See
// config/cansimd.yaml for the format. Every error names file, line, key and
// what was expected (ConfigError).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_set>
#include <utility>
#include <vector>

#include "config/plant_config.hpp"
#include "config/profile.hpp"

namespace cansim::config {

// `bus_model:` of an interface (docs/bus-model.md).
enum class BusModelChoice : std::uint8_t {
  kAuto,   // not given: timed on a virtual bus (vcan), the controller's pacing on real CAN
  kTimed,  // frames wait for the bus: arbitration and frame length at the bit rate
  kIdeal,  // every frame is on the bus the instant its node sends it
};

// `transport:` of an interface: a kernel CAN interface (SocketCAN, the
// default) or a bus cansimd serves over TCP in the socketcand protocol
// (docs/socketcand.md): then the name is the bus clients open.
enum class TransportKind : std::uint8_t { kSocketCan, kSocketcand };

// socketcand's own default port; `listen:` without a port, or no `listen:`, takes it.
inline constexpr std::uint16_t kSocketcandDefaultPort = 29536;

struct InterfaceConfig {
  std::string name;                 // "vcan0", "can0"; a socketcand bus: any name ("bench")
  std::uint32_t bit_rate_kbit = 0;  // 0: ask the kernel, else 250
  BusModelChoice bus_model = BusModelChoice::kAuto;
  TransportKind transport = TransportKind::kSocketCan;
  // socketcand: `listen: HOST:PORT` (a numeric address; port 0: a free one).
  // A host other than a loopback address needs `allow_remote: true`: the
  // protocol has no authentication.
  std::string listen_host = "127.0.0.1";
  std::uint16_t listen_port = kSocketcandDefaultPort;
  bool allow_remote = false;
  bool socketcand() const { return transport == TransportKind::kSocketcand; }
};

// What defines a node, as a digest (two independent 64-bit hashes): the
// profile file's text, its fleet entry's YAML, its index in the entry and
// its recording. Reload restarts a node whose digest changed; the texts
// themselves are not kept.
struct Digest {
  std::uint64_t a = 0, b = 0;
  // Appends `text` (order matters: add("ab").add("c") differs from add("a").add("bc")).
  Digest& add(std::string_view text);
  Digest& add(const Digest& other);
  bool operator==(const Digest&) const = default;
};

// Whether a numeric IP address is a loopback one (127.0.0.0/8, ::1,
// ::ffff:127.x.y.z); false for anything else.
bool is_loopback_address(const std::string& host);
// `HOST:PORT`, `[IPV6]:PORT`, or a bare host (the default port) into its
// parts; false when it is none of them or the host is not a numeric address.
bool parse_listen_address(const std::string& text, std::string& host, std::uint16_t& port);

struct NodeConfig {
  std::string key;          // stable identity: "<interface>/<name>/<index>" (storage, reload)
  std::string name;         // the entry's name (default "<profile>-<first node-ID>")
  std::uint32_t index = 0;  // position in a `count:` group
  std::string interface;
  std::uint8_t node_id = 1;             // 1..127 or 0xFF (LSS-unconfigured)
  std::uint32_t bit_rate_kbit = 250;    // the node's own rate
  std::optional<std::uint32_t> serial;  // 0x1018:04: `serial:`, serial_number_base or a count group's default, + index
  std::string record_file;              // `record:` CSV file of the node's physics (empty: none)
  // Shared by the nodes of one entry; a private copy (own layout) when the
  // entry overrides options or vendor parameters.
  std::shared_ptr<Profile> profile;
  Digest fingerprint;  // changes when anything that defines the node changes
  std::string origin;  // "<file>:<line>:<column>: nodes[i]": its entry, for error messages
};

// The table files a profile's parse read (FilesRead), with their texts' digests.
using TableDigests = std::vector<std::pair<std::string, Digest>>;

// A profile file as a parse loaded it: what a ProfileStore keeps.
struct LoadedProfile {
  std::string path;
  Digest text;  // of the file's text
  bool strict = false, strict_eds = false;
  std::shared_ptr<Profile> profile;
  TableDigests tables;
};

struct FleetConfig {
  std::string file;
  std::uint64_t seed = 1;
  std::vector<InterfaceConfig> interfaces;
  std::vector<NodeConfig> nodes;
  // Distinct profiles (base and variants) in first-use order.
  std::vector<std::shared_ptr<Profile>> profiles;
  // The base profiles (as their files are), in first-use order.
  std::vector<LoadedProfile> loaded;
  // `plants:` (docs/plants.md): only in the configuration file.
  PlantsConfig plants;

  const InterfaceConfig* interface(const std::string& name) const;
};

// Profiles loaded by earlier parses (the daemon's AddNodes calls), found
// again while their file's text is the same, so the nodes of many calls
// share one profile (its layout, OD defaults, tables and faults). It holds
// them weakly: a profile no node uses any more is gone.
class ProfileStore {
 public:
  // The profile parsed from this text, while every table file its parse
  // read still has the text it had (its `tables` then); else null.
  std::shared_ptr<Profile> find(const std::string& path, const Digest& text, bool strict, bool strict_eds,
                                TableDigests* tables = nullptr) const;
  void put(const LoadedProfile& loaded);
  void put_all(const FleetConfig& fleet) {
    for (const LoadedProfile& p : fleet.loaded) put(p);
  }

 private:
  struct Entry {
    Digest text;
    bool strict = false, strict_eds = false;
    std::weak_ptr<Profile> profile;
    TableDigests tables;
  };
  std::map<std::string, std::vector<Entry>> by_path_;
};

// The profile's physics reads a plant ({plant: ...}).
bool reads_plant(const Profile& profile);

// Where profile names are looked up, in order: as a path (relative to the
// config file's folder, then the cwd), then <dir>/<name>.yaml for each dir.
struct ProfileSearch {
  std::vector<std::string> dirs;
  bool strict = false;      // `cansimd --strict`: every profile loads in strict mode
  bool strict_eds = false;  // `cansimd --strict-eds`: what an EDS reader would repair is an error
  // Set for what a client names (AddNodes): a profile file must lie in one of
  // these folders (symbolic links resolved) or it is refused unopened, and one
  // that does not load is named by its path alone, never by its bytes.
  std::vector<std::string> confined_to;
  // Where loaded profiles are kept between parses (null: each parse loads its own).
  ProfileStore* store = nullptr;
};
// The default search: <config dir>/profiles, ./profiles, the installed folder.
ProfileSearch default_search(const std::string& config_file, const std::string& installed_dir);
// Resolves a profile reference; empty when not found.
std::string find_profile(const std::string& ref, const std::string& config_dir, const ProfileSearch& search);

// A YAML profile, or a CiA 306 EDS / DCF by its extension .eds / .dcf
// (docs/eds-dbc.md).
Profile load_any_profile(const std::string& path, bool strict = false, bool strict_eds = false);

FleetConfig load_fleet(const std::string& path, const ProfileSearch& search);
FleetConfig parse_fleet(const std::string& text, const std::string& file, const ProfileSearch& search);
// Nodes added at run time (control API AddNodes): `text` is one node entry,
// a list of entries, or a whole fleet document (without `plants:`: its nodes
// may read the running fleet's plants). Interfaces the fragment does
// not declare take their setting from `running` (else the kernel's / 250).
// Errors name `file`:line:column of the fragment; more entries or nodes than
// config/limits.hpp allows (for one call, or `running` with them) throw TooLarge.
FleetConfig parse_fleet_fragment(const std::string& text, const std::string& file, const ProfileSearch& search,
                                 const FleetConfig& running);
// The same against a running fleet known by its interfaces (their settings
// for the interfaces the fragment does not declare), its node count and its
// plants (what the fragment's nodes may read).
FleetConfig parse_fleet_fragment(const std::string& text, const std::string& file, const ProfileSearch& search,
                                 const std::vector<InterfaceConfig>& running_interfaces, std::size_t running_nodes,
                                 const PlantsConfig& running_plants);
// The node keys and node-IDs of a fleet, kept as its nodes come and go, so
// a fragment's collisions cost what the fragment's nodes cost.
class NodeIndex {
 public:
  void insert(const NodeConfig& n);
  void erase(const NodeConfig& n);
  void clear();
  // Throws the ConfigError merge_fleet() throws for the first node of
  // `extra` whose key or node-ID (on its interface) is taken, here or by an
  // earlier node of `extra`.
  void check(const FleetConfig& extra) const;

 private:
  std::unordered_set<std::string> keys_;
  std::map<std::pair<std::string, int>, std::string> ids_;  // (interface, node-ID) -> key
};
// Appends `extra`'s nodes, interfaces and profiles to `into`. A duplicate
// node key or a node-ID already used on the same interface throws
// ConfigError naming the node; `into` is then unchanged.
void merge_fleet(FleetConfig& into, const FleetConfig& extra);

// `cansimd --profile P [--interface IF] [--node-id N]`: one node.
FleetConfig single_node_fleet(const std::string& profile_ref, const std::string& interface, std::optional<int> node_id,
                              const ProfileSearch& search);

// A fleet configuration (a YAML mapping with `nodes:`) rather than a profile
// or an EDS; false for what cannot be read (the profile loader says why).
bool is_fleet_file(const std::string& path);

// `cansimd --record PATH`: a single node records to PATH; in a fleet, PATH is a
// folder and every node without its own `record:` records to
// PATH/<interface>-<name>-<index>.csv.
void apply_record_option(FleetConfig& fleet, const std::string& path, bool single_node);

}  // namespace cansim::config
