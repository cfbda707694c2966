#include <cstdio>
#include "personalities/registry.hpp"

#include <algorithm>

#include "personalities/cmp.hpp"
#include "personalities/dps.hpp"
#include "personalities/gems9000.hpp"
#include "personalities/generic.hpp"
#include "personalities/p92c.hpp"
#include "personalities/smc.hpp"
#include "personalities/strict.hpp"
#include "personalities/vendor_params.hpp"
#include "physics/random.hpp"

namespace cansim::personalities {

namespace {

// The device settings strict mode changes (strict.hpp); applied when `strict`.
template <class Settings>
std::vector<config::Quirk> device_strict(PreparedProfile& prepared, bool strict) {
  const Settings& faithful = device_settings<Settings>(prepared);
  std::vector<config::Quirk> changes = strict_changes(faithful);
  if (strict) {
    auto s = std::make_shared<Settings>(faithful);
    make_strict(*s);
    prepared.device = std::move(s);
  }
  return changes;
}
std::vector<config::Quirk> no_device_quirks(PreparedProfile&, bool) { return {}; }

struct Personality {
  const char* name;
  void (*prepare)(config::Profile&, PreparedProfile&);
  std::unique_ptr<Application> (*make)(const config::Profile&, const PreparedProfile&, const NodeContext&);
  std::vector<config::Quirk> (*strict)(PreparedProfile&, bool strict);
};

// Device personalities add one line each.
constexpr Personality kPersonalities[] = {
    {"generic", generic::prepare, generic::make, no_device_quirks},
    {"trafag-cmp", cmp::prepare, cmp::make, no_device_quirks},
    {"gems-9000", gems9000::prepare, gems9000::make, no_device_quirks},
    {"danfoss-p92c", p92c::prepare, p92c::make, no_device_quirks},
    {"adz-smc", smc::prepare, smc::make, device_strict<smc::Settings>},
    {"honeywell-dps", dps::prepare, dps::make, device_strict<dps::Settings>},
};

const Personality* find(const std::string& name) {
  for (const Personality& p : kPersonalities)
    if (name == p.name) return &p;
  return nullptr;
}

std::string known_names() {
  std::string s;
  for (const Personality& p : kPersonalities) s += (s.empty() ? "" : ", ") + std::string(p.name);
  return s;
}

}  // namespace

namespace {
// Where a missing-object error points: the `objects:` list, else the document.
config::Where objects_where(const config::Profile& profile, YAML::Node& node) {
  node = profile.root && profile.root.IsMap() && profile.root["objects"] ? profile.root["objects"] : profile.root;
  return config::Where{profile.file, "objects"};
}
}  // namespace

void require_objects(const config::Profile& profile, std::initializer_list<RequiredObject> objects) {
  for (const RequiredObject& o : objects)
    for (unsigned sub = o.first_sub; sub <= o.last_sub; ++sub) {
      const OdEntry* e = profile.layout->find(o.index, std::uint8_t(sub));
      if (e && !is_variable_size(e->type)) continue;
      YAML::Node at;
      config::Where w = objects_where(profile, at);
      char id[16];
      std::snprintf(id, sizeof id, "0x%04X:%02X", o.index, sub);
      config::fail(w, at, std::string("a numeric object ") + id + " (personality " + profile.personality +
                              " needs it for " + o.purpose + ")" + (e ? ", not a string or domain" : ""));
    }
}

void require_channels(const config::Profile& profile, const PreparedProfile& prepared, std::size_t count,
                      const char* purpose) {
  if (prepared.cia404 && prepared.cia404->channels.size() >= count) return;
  YAML::Node at;
  config::Where w = objects_where(profile, at);
  config::fail(w, at, "at least " + std::to_string(count) + " CiA 404 channel(s) (0x6130:01.." +
                          " with their vendor.cia404 channels; personality " + profile.personality + " needs them for " +
                          purpose + ")");
}

namespace {

// Strict mode of the chain and device settings; their deviations must be the
// `cia404.*` / `vendor.*` keys of the profile's `quirks:` (with references).
void prepare_strict(const Personality& p, config::Profile& profile, PreparedProfile& prepared, Cia404Profile& chain) {
  std::vector<config::Quirk> changes = strict_changes(chain.settings);
  if (profile.strict) make_strict(chain.settings);
  for (config::Quirk& q : p.strict(prepared, profile.strict)) changes.push_back(std::move(q));
  const config::Where w{profile.file, "quirks"};
  const YAML::Node quirks = profile.root && profile.root.IsMap() ? profile.root["quirks"] : YAML::Node();
  for (config::Quirk& q : changes) {
    q.reference = config::quirk_reference(profile, q.name);
    if (q.reference.empty())
      config::fail(w.child(q.name), quirks, "setting '" + q.name + "' deviates from CiA: `quirks:` needs its manual reference");
  }
  // A key may name a setting the profile keeps at its CiA value (a test or
  // fleet entry switched the quirk off), but it must be one strict mode knows.
  for (const auto& [name, ref] : profile.quirks) {
    if (name.rfind("cia404.", 0) != 0 && name.rfind("vendor.", 0) != 0) continue;
    if (!is_strict_setting(name)) config::fail(w.child(name), quirks[name], "not a chain or device setting strict mode changes");
  }
  prepared.setting_quirks = std::move(changes);
}

}  // namespace

std::vector<config::Quirk> quirk_inventory(const config::Profile& profile) {
  std::vector<config::Quirk> rows = config::option_quirks(profile);
  if (profile.prepared) {
    const auto& prepared = *std::static_pointer_cast<const PreparedProfile>(profile.prepared);
    rows.insert(rows.end(), prepared.setting_quirks.begin(), prepared.setting_quirks.end());
  }
  return rows;
}

void prepare_profile(config::Profile& profile) {
  const Personality* p = find(profile.personality);
  if (!p) {
    const YAML::Node n = profile.root && profile.root.IsMap() ? profile.root["personality"] : YAML::Node();
    config::fail(config::Where{profile.file, "personality"}, n,
                 "unknown personality '" + profile.personality + "' (expected: " + known_names() + ")");
  }
  auto prepared = std::make_shared<PreparedProfile>();
  const VendorParams vendor(profile);
  auto chain = std::make_shared<Cia404Profile>(
      *Cia404Profile::build(vendor.where("cia404"), vendor.node("cia404"), *profile.layout));
  prepared->cia404 = chain;
  IdentitySettings& id = prepared->identity;
  id.serial_per_node = vendor.integer("serial_number_base", id.serial_base, 0, 0xFFFFFFFF);
  prepared->physics = config::parse_physics_config(profile);
  p->prepare(profile, *prepared);
  prepare_strict(*p, profile, *prepared, *chain);
  profile.prepared = prepared;
}

std::unique_ptr<Application> make_application(const config::Profile& profile, const NodeContext& ctx) {
  if (!profile.prepared) {
    config::Profile copy = profile;  // shares the layout, so the hooks land on it
    prepare_profile(copy);
    return make_application(copy, ctx);
  }
  const Personality* p = find(profile.personality);
  if (!p) return nullptr;
  return p->make(profile, *std::static_pointer_cast<const PreparedProfile>(profile.prepared), ctx);
}

std::uint64_t node_seed(const NodeContext& ctx) {
  const std::uint64_t key = ctx.key.empty() ? ctx.index : physics::hash_string(ctx.key);
  return physics::derive_seed(ctx.fleet_seed, key);
}

std::unique_ptr<SensorSource> make_sensor_source(const PreparedProfile& prepared, const NodeContext& ctx) {
  const config::PhysicsConfig& c = prepared.physics;
  auto source = std::make_unique<SensorSource>(c.sensor, c.process, c.faults, node_seed(ctx));
  std::string error;
  if (!ctx.record_file.empty() && !source->record_to(ctx.record_file, &error))
    throw std::runtime_error(ctx.key + ": cannot record to " + ctx.record_file + ": " + error);
  return source;
}

}  // namespace cansim::personalities
