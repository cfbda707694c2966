#include "config/fleet.hpp"

#include "config/eds_reader.hpp"
#include "config/limits.hpp"
#include "config/physics_config.hpp"
#include "config/strict_mode.hpp"
#include "config/vendor_params.hpp"
#include "core/can_frame.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <unordered_map>

namespace cansim::config {

namespace fs = std::filesystem;

namespace {

bool is_file(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

std::string read_text(const std::string& path) { return read_regular_file(path, limits::kProfileFileBytes); }

bool valid_name(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.')) return false;
  return true;
}

std::string hex2(unsigned v) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "0x%02X", v);
  return buf;
}

std::uint64_t mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// What a node's digest gets of the tables its profile read.
void add_tables(Digest& digest, const TableDigests& tables) {
  for (const auto& [table, d] : tables) digest.add("\n--- table ").add(table).add(d);
}

TableDigests digests_of(const FilesRead& read) {
  TableDigests out;
  for (const auto& [path, text] : read.files()) out.emplace_back(path, Digest{}.add(text));
  return out;
}

// Loads each profile file once per configuration; variants are copies.
class ProfileCache {
 public:
  ProfileCache(const ProfileSearch& search, std::string config_dir, FleetConfig& out)
      : search_(search), config_dir_(std::move(config_dir)), out_(out) {}

  // The base profile for a reference, loaded on first use.
  std::shared_ptr<Profile> base(const Where& w, const YAML::Node& ref_node, std::string& path) {
    std::string ref = get_string(w, ref_node);
    path = find_profile(ref, config_dir_, search_);
    if (path.empty()) {
      std::string dirs;
      for (const auto& d : search_.dirs) dirs += (dirs.empty() ? "" : ", ") + d;
      fail(w, ref_node, "expected a profile file or a profile name found in: " + dirs);
    }
    const bool confined = !search_.confined_to.empty();
    if (confined && !inside_any(path, search_.confined_to)) {
      std::string dirs;
      for (const auto& d : search_.confined_to) dirs += (dirs.empty() ? "" : ", ") + d;
      fail(w, ref_node, "expected a profile name or a file in the profile folders (" + dirs + ")");
    }
    auto it = by_path_.find(path);
    if (it != by_path_.end()) return it->second;
    std::shared_ptr<Profile> p;
    try {
      texts_[path] = read_text(path);
      const Digest text = Digest{}.add(texts_[path]);
      TableDigests tables;
      if (search_.store) p = search_.store->find(path, text, search_.strict, search_.strict_eds, &tables);
      // Parsed unconfined (the fleet file's), with a table a confined parse refuses: parsed again, refused.
      if (p && confined && !std::all_of(tables.begin(), tables.end(), [&](const auto& t) {
            return inside_any(t.first, search_.confined_to);
          }))
        p = nullptr;
      if (!p) {
        FilesRead read;
        if (is_device_description(path))
          p = std::make_shared<Profile>(load_any_profile(path, search_.strict, search_.strict_eds));
        else  // parsed once: the variants of its entries start from copies
          p = std::make_shared<Profile>(parse_profile(document(path), path, search_.strict));
        tables = digests_of(read);
      }
      // What its nodes' digests start from: the text and its tables' (an
      // edited table restarts them at a reload).
      Digest& digest = digests_[path] = text;
      add_tables(digest, tables);
      out_.loaded.push_back({path, text, search_.strict, search_.strict_eds, p, std::move(tables)});
      if (search_.store) search_.store->put(out_.loaded.back());
    } catch (const TooLarge&) {
      throw;  // names the file and its size only
    } catch (const ConfigError&) {
      if (!confined) throw;
      throw ConfigError(path + ": not a valid profile (`cansimd --check --profile " + path + "` says why)");
    }
    by_path_[path] = p;
    out_.profiles.push_back(p);
    return p;
  }
  // The digest of the profile file's text and of the tables it read.
  const Digest& digest(const std::string& path) { return digests_[path]; }
  // The profile's YAML document (an empty node for an EDS / DCF), parsed
  // when first asked for (a profile from the store may need none).
  const YAML::Node& document(const std::string& path) {
    auto it = docs_.find(path);
    if (it != docs_.end()) return it->second;
    YAML::Node& doc = docs_[path];
    if (!is_device_description(path)) doc = load_yaml_text(texts_[path], path);
    return doc;
  }
  bool strict() const { return search_.strict; }
  void add_variant(std::shared_ptr<Profile> p) { out_.profiles.push_back(std::move(p)); }

 private:
  const ProfileSearch& search_;
  std::string config_dir_;
  FleetConfig& out_;
  std::map<std::string, std::shared_ptr<Profile>> by_path_;
  std::map<std::string, std::string> texts_;  // for this parse only
  std::map<std::string, Digest> digests_;
  std::map<std::string, YAML::Node> docs_;
};

// `transport: socketcand` and its keys (docs/socketcand.md).
void parse_transport(const Where& wi, const YAML::Node& v, InterfaceConfig& ic) {
  if (const YAML::Node& t = v["transport"]) {
    const std::string kind = get_string(wi.child("transport"), t);
    if (kind == "socketcand") ic.transport = TransportKind::kSocketcand;
    else if (kind != "socketcan")
      fail(wi.child("transport"), t, "expected socketcan (a kernel interface) or socketcand");
  }
  for (const char* key : {"listen", "allow_remote"})
    if (v[key] && !ic.socketcand()) fail(wi.child(key), v[key], "expected only with transport: socketcand");
  if (const YAML::Node& l = v["listen"]) {
    if (!parse_listen_address(get_string(wi.child("listen"), l), ic.listen_host, ic.listen_port))
      fail(wi.child("listen"), l,
           "expected HOST:PORT with a numeric address, e.g. 127.0.0.1:29536 or [::1]:0 (port 0: a free one)");
  }
  if (const YAML::Node& a = v["allow_remote"]) ic.allow_remote = get_bool(wi.child("allow_remote"), a);
  if (ic.socketcand() && !ic.allow_remote && !is_loopback_address(ic.listen_host))
    fail(wi.child("listen"), v["listen"],
         "expected a loopback address (127.0.0.1, ::1): the socketcand protocol has no authentication, anyone who "
         "reaches " +
             ic.listen_host + " could send frames on this bus; add allow_remote: true to listen there");
}

void parse_interfaces(const Where& w, const YAML::Node& map, FleetConfig& out) {
  if (!map.IsMap()) fail(w, map, "expected a mapping of interface names to settings, e.g. vcan0: {bit_rate: 250}");
  for (const auto& kv : map) {
    InterfaceConfig ic;
    ic.name = get_string(w, kv.first);
    Where wi = w.child(ic.name);
    if (ic.name.size() >= 16 || !valid_name(ic.name))
      fail(wi, kv.first, "expected a network interface name (at most 15 characters)");
    const YAML::Node& v = kv.second;
    if (v.IsDefined() && !v.IsNull()) {
      check_keys(wi, v, {"bit_rate", "bus_model", "transport", "listen", "allow_remote"});
      if (v["bit_rate"]) {
        ic.bit_rate_kbit = std::uint32_t(get_int(wi.child("bit_rate"), v["bit_rate"], 1, 1000));
        if (bit_rate_index(ic.bit_rate_kbit) < 0)
          fail(wi.child("bit_rate"), v["bit_rate"],
               "expected a CiA bit rate in kbit/s: 1000, 800, 500, 250, 125, 50, 20 or 10");
      }
      if (const YAML::Node& m = v["bus_model"]) {
        const std::string model = get_string(wi.child("bus_model"), m);
        if (model == "timed") ic.bus_model = BusModelChoice::kTimed;
        else if (model == "ideal") ic.bus_model = BusModelChoice::kIdeal;
        else fail(wi.child("bus_model"), m, "expected timed or ideal");
      }
      parse_transport(wi, v, ic);
    }
    out.interfaces.push_back(ic);
  }
}

// The entry's `physics:` / `sensor:` / `faults:` checked where they are
// written (the fleet file), then laid over the profile's document: physics
// channel by channel (gas_volume stands for both), sensor key by key within
// each channel, faults as a whole list.
// Returns the entry's process as parsed at its place (its plant terms name
// the fleet file).
// The `csv:` tables of an entry's physics named from the fleet file's folder,
// as the entry was checked (physics_config.cpp), not the profile's, where
// the merged document is parsed.
void tables_from(YAML::Node n, const fs::path& folder) {
  if (n.IsSequence())
    for (YAML::Node item : n) tables_from(item, folder);
  if (!n.IsMap()) return;
  for (auto kv : n) {
    if (kv.first.Scalar() == "csv" && kv.second.IsScalar() && !kv.second.Scalar().empty() &&
        kv.second.Scalar()[0] != '/')
      kv.second = (folder / kv.second.Scalar()).lexically_normal().string();
    else tables_from(kv.second, folder);
  }
}

// The folder a file's relative `csv:` paths are read from (physics_config.cpp), absolute.
fs::path folder_of(const std::string& file) {
  const fs::path parent = fs::path(file).parent_path();
  std::error_code ec;
  const fs::path folder = fs::absolute(parent.empty() ? fs::path(".") : parent, ec);
  return ec ? parent : folder;
}

std::optional<physics::ProcessSpec> merge_physics(const Where& w, const YAML::Node& entry, YAML::Node& root) {
  std::optional<physics::ProcessSpec> process;
  if (const YAML::Node& e = entry["physics"]) {
    process = parse_process(w.child("physics"), e);
    if (!e.IsMap()) return process;
    if (!root["physics"] || !root["physics"].IsMap()) root["physics"] = YAML::Node(YAML::NodeType::Map);
    YAML::Node physics = root["physics"];
    if (e["gas_volume"]) {
      physics.remove("pressure");
      physics.remove("temperature");
    } else if (e["pressure"] || e["temperature"]) {
      physics.remove("gas_volume");
    }
    for (const auto& kv : e) {
      YAML::Node value = YAML::Clone(kv.second);
      tables_from(value, folder_of(w.file));
      physics[kv.first.Scalar()] = value;
    }
  }
  if (const YAML::Node& e = entry["sensor"]) {
    parse_sensor(w.child("sensor"), e, default_sensor());
    if (!e.IsMap()) return process;
    if (!root["sensor"] || !root["sensor"].IsMap()) root["sensor"] = YAML::Node(YAML::NodeType::Map);
    YAML::Node sensor = root["sensor"];
    for (const auto& ch : e) {
      const std::string name = ch.first.Scalar();
      if (!sensor[name] || !sensor[name].IsMap()) sensor[name] = YAML::Node(YAML::NodeType::Map);
      YAML::Node into = sensor[name];
      if (ch.second.IsMap())
        for (const auto& kv : ch.second) into[kv.first.Scalar()] = YAML::Clone(kv.second);
    }
  }
  if (const YAML::Node& e = entry["faults"]) {
    parse_faults(w.child("faults"), e);
    root["faults"] = YAML::Clone(e);
  }
  return process;
}

// The plant terms of a channel the entry wrote keep the entry's place (the
// merged document was parsed again under the profile's name).
void keep_plant_origins(physics::ProcessSpec& merged, const physics::ProcessSpec& entry, const YAML::Node& physics) {
  auto fix = [](std::vector<physics::TermSpec>& into, const std::vector<physics::TermSpec>& from) {
    for (std::size_t i = 0; i < into.size() && i < from.size(); ++i) {
      auto* a = std::get_if<physics::PlantTermSpec>(&into[i]);
      const auto* b = std::get_if<physics::PlantTermSpec>(&from[i]);
      if (a && b) a->origin = b->origin;
    }
  };
  if (!physics.IsMap()) return;
  if (physics["pressure"]) fix(merged.pressure, entry.pressure);
  if (physics["temperature"]) fix(merged.temperature, entry.temperature);
}

// `over`'s keys laid on the mapping `into` (the last of a repeated key wins),
// one pass over each: a yaml-cpp lookup per key scans the whole map
// (quadratic in the keys).
void merge_keys(YAML::Node& into, const YAML::Node& over) {
  std::vector<std::pair<std::string, YAML::Node>> given;
  std::unordered_map<std::string, std::size_t> at;
  for (const auto& kv : over) {
    auto [it, fresh] = at.emplace(kv.first.Scalar(), given.size());
    if (fresh) given.emplace_back(it->first, kv.second);
    else given[it->second].second.reset(kv.second);  // re-points the handle, over stays as it is
  }
  for (auto kv : into) {  // handles to into's entries: assigning one sets it
    auto it = at.find(kv.first.Scalar());
    if (it == at.end()) continue;
    kv.second = YAML::Clone(given[it->second].second);
    at.erase(it);
  }
  for (const auto& [key, value] : given)
    if (at.count(key)) into.force_insert(key, YAML::Clone(value));
}

// Applies per-entry overrides to a private copy of the profile: its own
// layout and options, the personality part parsed again from the profile's
// document with the entry's `vendor:` keys merged over the profile's and its
// physics sections laid over the profile's.
std::shared_ptr<Profile> make_variant(const Where& w, const YAML::Node& entry, const Profile& base,
                                      const YAML::Node& base_doc, bool strict) {
  auto p = std::make_shared<Profile>(base);
  if (entry["strict"]) p->strict = strict || get_bool(w.child("strict"), entry["strict"]);
  apply_mode(*p, w.child("options"), entry["options"]);  // strict mode first, the entry's options on top
  // A device description has no YAML sections: the entry's are the only ones.
  YAML::Node root = is_device_description(base.file) ? YAML::Node(YAML::NodeType::Map) : YAML::Clone(base_doc);
  YAML::Node vendor = root["vendor"] ? YAML::Clone(root["vendor"]) : YAML::Node(YAML::NodeType::Map);
  if (entry["vendor"]) {
    const YAML::Node& v = entry["vendor"];
    if (!v.IsMap()) fail(w.child("vendor"), v, "expected a mapping of vendor parameters");
    if (!vendor.IsMap()) vendor = YAML::Node(YAML::NodeType::Map);
    merge_keys(vendor, v);
  }
  const std::optional<physics::ProcessSpec> entry_process = merge_physics(w, entry, root);
  const VendorLayer over{w.child("vendor"), entry["vendor"]};  // the entry's keys are reported in the fleet file
  parse_personality(*p, root, vendor, entry["vendor"] ? &over : nullptr);
  if (entry_process) keep_plant_origins(p->physics.process, *entry_process, entry["physics"]);
  return p;
}

// `record:` of an entry: "{id}" becomes the node-ID; a `count:` group without
// it gets "-<node-ID>" before the extension so its nodes do not share a file.
std::string record_file_name(std::string pattern, std::uint8_t node_id, bool group) {
  const std::string id = std::to_string(node_id);
  if (const auto at = pattern.find("{id}"); at != std::string::npos) return pattern.replace(at, 4, id);
  if (!group) return pattern;
  const fs::path p(pattern);
  return (p.parent_path() / (p.stem().string() + "-" + id + p.extension().string())).string();
}

// The serial number of the first node of an entry without `serial:` (each
// node adds its index): the profile's serial_number_base, else for a group
// the profile's 0x1018:04 default.
std::optional<std::uint32_t> first_serial(const Profile& profile, int count) {
  if (profile.identity.serial_per_node) return profile.identity.serial_base;
  if (count < 2) return std::nullopt;
  const OdEntry* e = profile.layout->find(0x1018, 4);
  return e && e->default_bytes.size() >= 4 ? get_u32(e->default_bytes.data()) : 0;
}

void parse_node_entry(const Where& w, const YAML::Node& entry, ProfileCache& cache, FleetConfig& out,
                      const std::string& plants_fingerprint) {
  check_keys(w, entry,
             {"profile", "interface", "node_id", "count", "name", "serial", "bit_rate", "record", "options", "vendor",
              "physics", "sensor", "faults", "strict"});
  if (!entry["profile"]) fail(w.child("profile"), entry, "missing required key 'profile'");
  if (!entry["interface"]) fail(w.child("interface"), entry, "missing required key 'interface'");
  std::string path;
  auto profile = cache.base(w.child("profile"), entry["profile"], path);
  std::string iface = get_string(w.child("interface"), entry["interface"]);
  if (!out.interface(iface)) {
    std::string names;
    for (const auto& i : out.interfaces) names += (names.empty() ? "" : ", ") + i.name;
    fail(w.child("interface"), entry["interface"],
         "expected an interface declared under 'interfaces:' (" + (names.empty() ? "none declared" : names) + ")");
  }
  int first_id = profile->node_id;
  if (entry["node_id"]) {
    first_id = int(get_int(w.child("node_id"), entry["node_id"], 1, 255));
    if (first_id > 127 && first_id != 255)
      fail(w.child("node_id"), entry["node_id"], "expected a node-ID 1..127 or 255 (LSS-unconfigured)");
  }
  int count = entry["count"] ? int(get_int(w.child("count"), entry["count"], 1, 127)) : 1;
  if (first_id != 255 && first_id + count - 1 > 127)
    fail(w.child("count"), entry["count"],
         "expected a count that keeps node-IDs within 1..127 (first node-ID " + std::to_string(first_id) + ")");
  std::string name = profile->name.empty() ? fs::path(path).stem().string() : profile->name;
  name += '-';  // not "-" + std::to_string(): GCC 12 -O3 reports a false -Wrestrict there
  name += std::to_string(first_id);
  if (entry["name"]) {
    name = get_string(w.child("name"), entry["name"]);
    if (!valid_name(name)) fail(w.child("name"), entry["name"], "expected a name of letters, digits, '-', '_' or '.'");
  }
  std::uint32_t bit_rate = profile->bit_rate_kbit;
  if (entry["bit_rate"]) {
    bit_rate = std::uint32_t(get_int(w.child("bit_rate"), entry["bit_rate"], 1, 1000));
    if (bit_rate_index(bit_rate) < 0)
      fail(w.child("bit_rate"), entry["bit_rate"],
           "expected a CiA bit rate in kbit/s: 1000, 800, 500, 250, 125, 50, 20 or 10");
  }
  std::optional<std::uint32_t> serial;
  if (entry["serial"]) serial = std::uint32_t(get_int(w.child("serial"), entry["serial"], 0, 0xFFFFFFFF));
  std::string record;
  if (entry["record"]) {
    record = get_string(w.child("record"), entry["record"]);
    if (record.empty() || record.back() == '/')
      fail(w.child("record"), entry["record"], "expected a CSV file name, e.g. recordings/dps-{id}.csv");
  }
  TableDigests variant_tables;  // an entry's own tables (`physics:` with a `csv:`)
  if (entry["options"] || entry["vendor"] || entry["physics"] || entry["sensor"] || entry["faults"] ||
      entry["strict"]) {
    FilesRead read;
    profile = make_variant(w, entry, *profile, cache.document(path), cache.strict());
    cache.add_variant(profile);
    variant_tables = digests_of(read);
  }
  if (!serial) serial = first_serial(*profile, count);
  // A node that reads a plant restarts when the plants change.
  Digest fingerprint_base = Digest(cache.digest(path)).add("\n---\n").add(YAML::Dump(entry));
  add_tables(fingerprint_base, variant_tables);
  if (reads_plant(*profile)) fingerprint_base.add("\n--- plants\n").add(plants_fingerprint);
  // Appended piece by piece: GCC 12 -O3 reports a false -Wrestrict for a
  // chain of std::string operator+ here (as in name += '-' above).
  std::string origin = w.file;
  if (entry.Mark().line >= 0) {
    origin += ':';
    origin += std::to_string(entry.Mark().line + 1);
    origin += ':';
    origin += std::to_string(entry.Mark().column + 1);
  }
  origin += ": ";
  origin += w.path;
  for (int i = 0; i < count; ++i) {
    NodeConfig n;
    n.name = name;
    n.index = std::uint32_t(i);
    n.key = iface + "/" + name + "/" + std::to_string(i);
    n.interface = iface;
    n.node_id = std::uint8_t(first_id == 255 ? 255 : first_id + i);
    n.bit_rate_kbit = bit_rate;
    if (serial) n.serial = *serial + std::uint32_t(i);
    if (!record.empty()) n.record_file = record_file_name(record, n.node_id, count > 1);
    n.profile = profile;
    n.fingerprint = Digest(fingerprint_base).add("\nindex ").add(std::to_string(i));
    n.origin = origin;
    out.nodes.push_back(std::move(n));
  }
}

// Node-ID collisions on one interface and duplicate keys are configuration errors.
void check_collisions(const Where& w, const YAML::Node& list, const FleetConfig& out,
                      const std::vector<std::size_t>& entry_of) {
  std::map<std::pair<std::string, int>, std::size_t> ids;
  std::set<std::string> keys;
  for (std::size_t i = 0; i < out.nodes.size(); ++i) {
    const NodeConfig& n = out.nodes[i];
    std::size_t e = entry_of[i];
    if (!keys.insert(n.key).second)
      fail(w.item(e).child("name"), list[e],
           "expected a name unique on interface " + n.interface + " ('" + n.name + "' is used twice)");
    if (n.node_id == 255) continue;
    auto [it, fresh] = ids.emplace(std::make_pair(n.interface, int(n.node_id)), e);
    if (!fresh)
      fail(w.item(e).child("node_id"), list[e],
           "node-ID " + std::to_string(n.node_id) + " (" + hex2(n.node_id) + ") is already used on " + n.interface +
               " by nodes[" + std::to_string(it->second) + "]; expected a free node-ID");
  }
}

// The interfaces the node entries name that `interfaces:` does not declare,
// added to it with the running fleet's bit rate for that name (else none:
// the kernel's rate for real CAN, else 250).
void declare_entry_interfaces(YAML::Node root, const std::string& file, const FleetConfig& running) {
  YAML::Node ifaces = root["interfaces"] ? root["interfaces"] : YAML::Node(YAML::NodeType::Map);
  if (!ifaces.IsMap() || !root["nodes"].IsSequence()) return;
  std::size_t i = 0;
  for (const auto& entry : root["nodes"]) {
    const Where wi = Where{file, "nodes"}.item(i++);
    if (!entry.IsMap() || !entry["interface"] || !entry["interface"].IsScalar()) continue;
    const std::string name = entry["interface"].Scalar();
    if (ifaces[name]) continue;
    // Checked here, where the name has a line: the interface added below has none.
    if (name.size() >= 16 || !valid_name(name))
      fail(wi.child("interface"), entry["interface"], "expected a network interface name (at most 15 characters)");
    YAML::Node setting(YAML::NodeType::Map);
    if (const InterfaceConfig* ic = running.interface(name)) {
      if (ic->bit_rate_kbit) setting["bit_rate"] = ic->bit_rate_kbit;
      if (ic->bus_model != BusModelChoice::kAuto)
        setting["bus_model"] = ic->bus_model == BusModelChoice::kTimed ? "timed" : "ideal";
      if (ic->socketcand()) {
        setting["transport"] = "socketcand";
        setting["listen"] = ic->listen_host + ":" + std::to_string(ic->listen_port);
        if (ic->listen_host.find(':') != std::string::npos)
          setting["listen"] = "[" + ic->listen_host + "]:" + std::to_string(ic->listen_port);
        setting["allow_remote"] = ic->allow_remote;
      }
    }
    ifaces[name] = setting;
  }
  root["interfaces"] = ifaces;
}

// `interfaces:` may be left out: then it is every interface the nodes name,
// at its default rate. Where it is given, a node's interface must be in it
// (a misspelt name is an error, not a new bus).
FleetConfig parse_root(const YAML::Node& root, const std::string& file, const ProfileSearch& search,
                       const PlantsConfig* running_plants = nullptr) {
  Where w{file, ""};
  if (!root.IsMap()) fail(w, root, "expected a mapping with 'nodes:' (and 'interfaces:')");
  check_keys(w, root, {"seed", "interfaces", "nodes", "plants"});
  if (running_plants && root["plants"])
    fail(w.child("plants"), root["plants"],
         "plants are defined in the configuration file only (a node added may read them)");
  // The node list first: without `interfaces:` the interfaces come from it.
  if (!root["nodes"]) fail(w.child("nodes"), root, "missing required key 'nodes'");
  const YAML::Node& list = root["nodes"];
  Where wn = w.child("nodes");
  if (!list.IsSequence()) fail(wn, list, "expected a list of node entries");
  if (!root["interfaces"]) declare_entry_interfaces(root, file, FleetConfig{});
  FleetConfig out;
  out.file = file;
  if (root["seed"]) out.seed = get_uint(w.child("seed"), root["seed"]);
  parse_interfaces(w.child("interfaces"), root["interfaces"], out);
  out.plants = running_plants ? *running_plants : parse_plants(w.child("plants"), root["plants"]);
  std::string dir = fs::path(file).parent_path().string();
  ProfileCache cache(search, dir.empty() ? "." : dir, out);
  std::vector<std::size_t> entry_of;
  for (std::size_t i = 0; i < list.size(); ++i) {
    parse_node_entry(wn.item(i), list[i], cache, out, out.plants.fingerprint);
    entry_of.resize(out.nodes.size(), i);
  }
  check_collisions(wn, list, out, entry_of);
  check_plants(out, /*bindings=*/running_plants == nullptr);
  if (running_plants) out.plants = PlantsConfig{};  // the running fleet's, not the fragment's
  return out;
}

}  // namespace

bool reads_plant(const Profile& profile) {
  const physics::ProcessSpec& p = profile.physics.process;
  auto plant = [](const physics::TermSpec& t) { return std::holds_alternative<physics::PlantTermSpec>(t); };
  return std::any_of(p.pressure.begin(), p.pressure.end(), plant) ||
         std::any_of(p.temperature.begin(), p.temperature.end(), plant);
}

Profile load_any_profile(const std::string& path, bool strict, bool strict_eds) {
  return is_device_description(path) ? load_eds_profile(path, strict, strict_eds) : load_profile(path, strict);
}

bool is_loopback_address(const std::string& host) {
  in_addr v4{};
  if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (inet_pton(AF_INET6, host.c_str(), &v6) != 1) return false;
  return IN6_IS_ADDR_LOOPBACK(&v6) || (IN6_IS_ADDR_V4MAPPED(&v6) && v6.s6_addr[12] == 127);
}

bool parse_listen_address(const std::string& text, std::string& host, std::uint16_t& port) {
  std::string h = text, p;
  if (!text.empty() && text.front() == '[') {  // [IPv6]:PORT
    const std::size_t close = text.find(']');
    if (close == std::string::npos) return false;
    h = text.substr(1, close - 1);
    if (close + 1 < text.size()) {
      if (text[close + 1] != ':') return false;
      p = text.substr(close + 2);
      if (p.empty()) return false;
    }
  } else if (const std::size_t colon = text.rfind(':');
             colon != std::string::npos && text.find(':') == colon) {  // one colon: IPv4:PORT
    h = text.substr(0, colon);
    p = text.substr(colon + 1);
    if (p.empty()) return false;
  }
  unsigned char probe[sizeof(in6_addr)];
  if (inet_pton(AF_INET, h.c_str(), probe) != 1 && inet_pton(AF_INET6, h.c_str(), probe) != 1) return false;
  std::uint32_t value = kSocketcandDefaultPort;
  if (!p.empty()) {
    auto [end, ec] = std::from_chars(p.data(), p.data() + p.size(), value);
    if (ec != std::errc{} || end != p.data() + p.size() || value > 65535) return false;
  }
  host = h;
  port = std::uint16_t(value);
  return true;
}

const InterfaceConfig* FleetConfig::interface(const std::string& name) const {
  for (const auto& i : interfaces)
    if (i.name == name) return &i;
  return nullptr;
}

// Two independent hashes of each piece: libstdc++'s (MurmurHash64A) and
// FNV-1a, each chained through a finalizer with the piece's length.
Digest& Digest::add(std::string_view text) {
  std::uint64_t fnv = 0xCBF29CE484222325ull;
  for (char c : text) {
    fnv ^= static_cast<unsigned char>(c);
    fnv *= 0x100000001B3ull;
  }
  a = mix(a * 0x9E3779B97F4A7C15ull + std::hash<std::string_view>{}(text) + text.size());
  b = mix((b ^ fnv) * 0xD6E8FEB86659FD93ull + text.size());
  return *this;
}

Digest& Digest::add(const Digest& other) {
  const std::uint64_t both[2] = {other.a, other.b};
  return add(std::string_view(reinterpret_cast<const char*>(both), sizeof both));
}

ProfileSearch default_search(const std::string& config_file, const std::string& installed_dir) {
  ProfileSearch s;
  if (!config_file.empty()) {
    fs::path dir = fs::path(config_file).parent_path();
    s.dirs.push_back((dir.empty() ? fs::path("profiles") : dir / "profiles").string());
    // config/cansimd.yaml in the source tree sits next to profiles/.
    s.dirs.push_back(((dir.empty() ? fs::path("..") : dir / "..") / "profiles").lexically_normal().string());
  }
  s.dirs.push_back("profiles");
  if (!installed_dir.empty()) s.dirs.push_back(installed_dir);
  return s;
}

std::string find_profile(const std::string& ref, const std::string& config_dir, const ProfileSearch& search) {
  if (ref.empty()) return {};
  fs::path p(ref);
  if (p.is_absolute()) return is_file(p) ? p.string() : std::string();
  bool looks_like_path = ref.find('/') != std::string::npos || p.extension() == ".yaml" || p.extension() == ".yml" ||
                         is_device_description(ref);
  if (looks_like_path) {
    if (!config_dir.empty() && is_file(fs::path(config_dir) / p)) return (fs::path(config_dir) / p).string();
    if (is_file(p)) return p.string();
  }
  for (const auto& dir : search.dirs) {
    fs::path candidate = fs::path(dir) / (p.extension().empty() ? ref + ".yaml" : ref);
    if (is_file(candidate)) return candidate.string();
  }
  return {};
}

FleetConfig parse_fleet(const std::string& text, const std::string& file, const ProfileSearch& search) {
  return parse_root(load_yaml_text(text, file), file, search);
}

FleetConfig parse_fleet_fragment(const std::string& text, const std::string& file, const ProfileSearch& search,
                                 const FleetConfig& running) {
  return parse_fleet_fragment(text, file, search, running.interfaces, running.nodes.size(), running.plants);
}

FleetConfig parse_fleet_fragment(const std::string& text, const std::string& file, const ProfileSearch& search,
                                 const std::vector<InterfaceConfig>& running_interfaces, std::size_t running_nodes,
                                 const PlantsConfig& running_plants) {
  const YAML::Node given = load_yaml_text(text, file);
  // The fragment's own nodes keep their marks, so errors point into `text`.
  YAML::Node root(YAML::NodeType::Map);
  if (given.IsMap() && given["nodes"]) {
    root = given;
  } else if (given.IsMap() || given.IsSequence()) {
    YAML::Node list(YAML::NodeType::Sequence);
    if (given.IsMap()) list.push_back(given);
    else
      for (const auto& e : given) list.push_back(e);
    root["nodes"] = list;
  } else {
    fail(Where{file, ""}, given, "expected a node entry, a list of node entries or a fleet document");
  }
  // The bounds name the fragment's node list (a list built here has no mark).
  const Where nodes{file, "nodes"};
  const YAML::Node list = given.IsMap() && given["nodes"] ? given["nodes"] : given;
  if (root["nodes"].IsSequence() && root["nodes"].size() > limits::kAddNodesEntries)
    fail_too_large(nodes, list,
                   std::to_string(root["nodes"].size()) + " node entries; expected at most " +
                       std::to_string(limits::kAddNodesEntries) + " in one call");
  FleetConfig running;  // only its interfaces: their settings for the entries that do not declare them
  running.interfaces = running_interfaces;
  declare_entry_interfaces(root, file, running);
  std::optional<ConfinedFiles> tables;  // a client's `csv:` tables, as its profiles
  if (!search.confined_to.empty()) tables.emplace(search.confined_to);
  FleetConfig out = parse_root(root, file, search, &running_plants);
  if (out.nodes.size() > limits::kAddNodesNodes)
    fail_too_large(nodes, list,
                   std::to_string(out.nodes.size()) + " nodes; expected at most " +
                       std::to_string(limits::kAddNodesNodes) + " in one call");
  if (running_nodes + out.nodes.size() > limits::kFleetNodes)
    fail_too_large(nodes, list,
                   std::to_string(out.nodes.size()) + " more nodes would make the fleet " +
                       std::to_string(running_nodes + out.nodes.size()) + "; expected at most " +
                       std::to_string(limits::kFleetNodes));
  return out;
}

namespace {
bool tables_unchanged(const TableDigests& tables) {
  for (const auto& [path, digest] : tables) {
    try {
      if (!(Digest{}.add(read_regular_file(path, limits::kTableFileBytes)) == digest)) return false;
    } catch (const std::exception&) {
      return false;  // gone or unreadable: the parse says why
    }
  }
  return true;
}
}  // namespace

std::shared_ptr<Profile> ProfileStore::find(const std::string& path, const Digest& text, bool strict, bool strict_eds,
                                            TableDigests* tables) const {
  auto it = by_path_.find(path);
  if (it == by_path_.end()) return nullptr;
  for (const Entry& e : it->second)
    if (e.text == text && e.strict == strict && e.strict_eds == strict_eds)
      if (auto p = e.profile.lock(); p && tables_unchanged(e.tables)) {
        if (tables) *tables = e.tables;
        return p;
      }
  return nullptr;
}

void ProfileStore::put(const LoadedProfile& p) {
  std::vector<Entry>& entries = by_path_[p.path];
  std::erase_if(entries, [&](const Entry& e) {
    return e.profile.expired() || (e.text == p.text && e.strict == p.strict && e.strict_eds == p.strict_eds);
  });
  entries.push_back({p.text, p.strict, p.strict_eds, p.profile, p.tables});
}

void NodeIndex::insert(const NodeConfig& n) {
  keys_.insert(n.key);
  if (n.node_id != 255) ids_[{n.interface, n.node_id}] = n.key;
}

void NodeIndex::erase(const NodeConfig& n) {
  keys_.erase(n.key);
  if (n.node_id == 255) return;
  auto it = ids_.find({n.interface, n.node_id});
  if (it != ids_.end() && it->second == n.key) ids_.erase(it);
}

void NodeIndex::clear() {
  keys_.clear();
  ids_.clear();
}

void NodeIndex::check(const FleetConfig& extra) const {
  std::unordered_set<std::string> keys;  // extra's own, so far
  std::map<std::pair<std::string, int>, std::string> ids;
  for (const NodeConfig& n : extra.nodes) {
    // "<file>:<line>:<column>: nodes[i]" of the entry (just the file for nodes not from a fleet entry).
    const std::string at = n.origin.empty() ? extra.file + ": " + n.key : n.origin;
    if (keys_.count(n.key) || keys.count(n.key))
      throw ConfigError(at + ".name: node " + n.key + " already exists; expected a new name");
    keys.insert(n.key);
    if (n.node_id == 255) continue;
    const std::pair<std::string, int> id{n.interface, n.node_id};
    auto it = ids_.find(id);
    const std::string* owner = it != ids_.end() ? &it->second : nullptr;
    if (auto own = ids.find(id); !owner && own != ids.end()) owner = &own->second;
    if (owner)
      throw ConfigError(at + ".node_id: node " + n.key + ": node-ID " + std::to_string(n.node_id) + " (" +
                        hex2(n.node_id) + ") is already used on " + n.interface + " by " + *owner +
                        "; expected a free node-ID");
    ids[id] = n.key;
  }
}

void merge_fleet(FleetConfig& into, const FleetConfig& extra) {
  NodeIndex index;
  for (const NodeConfig& n : into.nodes) index.insert(n);
  index.check(extra);
  for (const InterfaceConfig& ic : extra.interfaces)
    if (!into.interface(ic.name)) into.interfaces.push_back(ic);
  into.nodes.insert(into.nodes.end(), extra.nodes.begin(), extra.nodes.end());
  into.profiles.insert(into.profiles.end(), extra.profiles.begin(), extra.profiles.end());
  into.loaded.insert(into.loaded.end(), extra.loaded.begin(), extra.loaded.end());
}

FleetConfig load_fleet(const std::string& path, const ProfileSearch& search) {
  return parse_root(load_yaml_file(path), path, search);
}

FleetConfig single_node_fleet(const std::string& profile_ref, const std::string& interface, std::optional<int> node_id,
                              const ProfileSearch& search) {
  std::string path = find_profile(profile_ref, ".", search);
  if (path.empty()) throw ConfigError(profile_ref + ": profile not found (expected a file or a profile name)");
  FleetConfig out;
  out.file = path;
  FilesRead read;
  auto profile = std::make_shared<Profile>(load_any_profile(path, search.strict, search.strict_eds));
  out.profiles.push_back(profile);
  InterfaceConfig ic;
  ic.name = interface;
  ic.bit_rate_kbit = profile->bit_rate_kbit;
  out.interfaces.push_back(ic);
  NodeConfig n;
  n.name = profile->name.empty() ? fs::path(path).stem().string() : profile->name;
  n.key = interface + "/" + n.name + "/0";
  n.interface = interface;
  n.node_id = std::uint8_t(node_id ? *node_id : profile->node_id);
  n.bit_rate_kbit = profile->bit_rate_kbit;
  n.profile = profile;
  n.fingerprint = Digest{}.add(read_text(path));
  add_tables(n.fingerprint, digests_of(read));
  out.nodes.push_back(std::move(n));
  check_plants(out);  // a profile that reads a plant needs a fleet that has it
  return out;
}

void apply_record_option(FleetConfig& fleet, const std::string& path, bool single_node) {
  if (path.empty()) return;
  for (NodeConfig& n : fleet.nodes) {
    if (single_node) {
      n.record_file = path;
    } else if (n.record_file.empty()) {
      std::string file = n.key;
      std::replace(file.begin(), file.end(), '/', '-');
      n.record_file = (fs::path(path) / (file + ".csv")).string();
    }
    n.fingerprint.add("\nrecord ").add(n.record_file);
  }
}

bool is_fleet_file(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext != ".yaml" && ext != ".yml") return false;
  try {
    const YAML::Node root = load_yaml_file(path);
    return root.IsMap() && root["nodes"];
  } catch (const std::exception&) {
    return false;
  }
}

}  // namespace cansim::config
