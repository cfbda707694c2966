#include "config/strict_mode.hpp"

#include <algorithm>
#include <cstdio>
#include <variant>

#include "personalities/strict.hpp"

namespace cansim::config {

namespace {

std::string object_key(std::uint16_t index, std::uint8_t sub) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "object 0x%04X:%02X", index, sub);
  return buf;
}

bool is_setting_key(const std::string& name) { return name.rfind("cia404.", 0) == 0 || name.rfind("vendor.", 0) == 0; }

std::string describe(const OdEntry* e) {
  if (!e) return "absent";
  std::string s = std::string(type_name(e->type)) + " " + access_name(e->access);
  if (!is_variable_size(e->type) && e->default_bytes.size() <= 8) {
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < e->default_bytes.size(); ++i) v |= std::uint64_t(e->default_bytes[i]) << (8 * i);
    char buf[40];
    std::snprintf(buf, sizeof buf, " default 0x%llX%s", static_cast<unsigned long long>(v),
                  e->default_plus_node_id ? "+$NODEID" : "");
    s += buf;
  }
  return s;
}

std::vector<std::string> deviating_options(const NodeOptions& faithful) {
  NodeOptions strict = faithful;
  make_strict(strict);
  return differing_options(faithful, strict);
}

void parse_quirks(const Where& w, const YAML::Node& map, Profile& p) {
  if (!map) return;
  if (!map.IsMap()) fail(w, map, "expected a mapping of quirk names to manual references");
  for (const auto& kv : map) {
    const std::string name = kv.first.Scalar();
    p.quirks.emplace_back(name, get_string(w.child(name), kv.second));
  }
}

// Every key names a deviation of this profile; every deviation has a key.
void check_quirks(const Where& w, const YAML::Node& map, const Profile& p) {
  const std::vector<std::string> deviating = deviating_options(*p.faithful_options);
  auto listed = [&](const std::string& name) {
    return std::any_of(p.quirks.begin(), p.quirks.end(), [&](const auto& q) { return q.first == name; });
  };
  for (const auto& quirk : p.quirks) {
    const std::string& name = quirk.first;  // not a structured binding: the lambda below captures it
    const std::string& ref = quirk.second;
    const YAML::Node at = map[name];
    if (ref.empty()) fail(w.child(name), at, "expected the manual's page or table that documents the quirk");
    if (is_setting_key(name)) continue;
    if (name.rfind("object ", 0) == 0) {
      const bool patched = std::any_of(p.strict_objects.begin(), p.strict_objects.end(),
                                       [&](const OdEntry& e) { return object_key(e.index, e.sub) == name; });
      if (!patched) fail(w.child(name), at, "expected a `strict_objects:` entry for " + name);
      continue;
    }
    const OptionInfo* info = find_option(name);
    if (!info)
      fail(w.child(name), at, "unknown option (quirks name options, 'object 0xIIII:SS', cia404.* or vendor.*)");
    if (!info->deviation) fail(w.child(name), at, "a setting, not a deviation (node_options.hpp kind SETTING)");
    if (std::find(deviating.begin(), deviating.end(), name) == deviating.end())
      fail(w.child(name), at, "the profile keeps the CiA value of this option: nothing to document");
  }
  for (const std::string& name : deviating)
    if (!listed(name))
      fail(w.child(name), map, "option '" + name + "' deviates from CiA: `quirks:` needs its manual reference");
  for (const OdEntry& e : p.strict_objects)
    if (!listed(object_key(e.index, e.sub)))
      fail(w.child(object_key(e.index, e.sub)), map, "strict_objects entry needs its manual reference in `quirks:`");
}

std::shared_ptr<OdLayout> patched_layout(const OdLayout& faithful, const std::vector<OdEntry>& patches) {
  auto out = std::make_shared<OdLayout>();
  auto patch_of = [&](const OdEntry& e) {
    return std::find_if(patches.begin(), patches.end(),
                        [&](const OdEntry& q) { return q.index == e.index && q.sub == e.sub; });
  };
  for (const OdEntry& e : faithful.entries()) {
    auto q = patch_of(e);
    out->add(q == patches.end() ? e : *q);
  }
  for (const OdEntry& q : patches) out->add(q);  // the added objects (replacements are there already)
  out->finalize();
  return out;
}

}  // namespace

void parse_strict_sections(const Where& w, const YAML::Node& root, Profile& p, bool force_strict) {
  p.faithful_options = std::make_shared<const NodeOptions>(*p.options);
  p.faithful_layout = p.layout;
  if (root["strict_objects"]) {
    OdLayout patches;
    parse_objects(w.child("strict_objects"), root["strict_objects"], patches);
    p.strict_objects.assign(patches.entries().begin(), patches.entries().end());
  }
  // A profile without `quirks:` (a test or experiment) is not checked; its
  // deviations show in the inventory as undocumented.
  if (root["quirks"]) {
    p.quirks_checked = true;
    parse_quirks(w.child("quirks"), root["quirks"], p);
    check_quirks(w.child("quirks"), root["quirks"], p);
  }
  p.strict = force_strict || (root["strict"] && get_bool(w.child("strict"), root["strict"]));
  if (p.strict) apply_mode(p, w.child("options"), YAML::Node());
}

void apply_mode(Profile& p, const Where& w, const YAML::Node& overrides) {
  auto options = std::make_shared<NodeOptions>(*p.faithful_options);
  if (p.strict) make_strict(*options);
  if (overrides && !overrides.IsNull()) parse_options(w, overrides, *options);
  p.options = options;
  p.layout =
      p.strict ? patched_layout(*p.faithful_layout, p.strict_objects) : std::make_shared<OdLayout>(*p.faithful_layout);
}

namespace {

template <class Settings>
void device_strictness(Settings& s, bool strict, std::vector<Quirk>& changes) {
  for (Quirk& q : personalities::strict_changes(s)) changes.push_back(std::move(q));
  if (strict) personalities::make_strict(s);
}
void device_strictness(model::GenericSettings&, bool, std::vector<Quirk>&) {}
void device_strictness(model::P92cSettings&, bool, std::vector<Quirk>&) {}
void device_strictness(model::GemsSettings&, bool, std::vector<Quirk>&) {}
void device_strictness(model::CmpSettings&, bool, std::vector<Quirk>&) {}
void device_strictness(model::AnalogOutputSettings&, bool, std::vector<Quirk>&) {}  // a stand-in: CiA 401 as written

}  // namespace

void apply_setting_strictness(Profile& p, model::Cia404Settings& chain, const YAML::Node& root) {
  std::vector<Quirk> changes = personalities::strict_changes(chain);
  if (p.strict) personalities::make_strict(chain);
  std::visit([&](auto& s) { device_strictness(s, p.strict, changes); }, p.device);
  const Where w{p.file, "quirks"};
  const YAML::Node quirks = root["quirks"];
  for (Quirk& q : changes) {
    q.reference = quirk_reference(p, q.name);
    if (q.reference.empty())
      fail(w.child(q.name), quirks, "setting '" + q.name + "' deviates from CiA: `quirks:` needs its manual reference");
  }
  // A key may name a setting the profile keeps at its CiA value (a test or
  // fleet entry switched the quirk off), but it must be one strict mode knows.
  for (const auto& [name, ref] : p.quirks) {
    if (!is_setting_key(name)) continue;
    if (!personalities::is_strict_setting(name))
      fail(w.child(name), quirks[name], "not a chain or device setting strict mode changes");
  }
  p.setting_quirks = std::move(changes);
}

std::vector<Quirk> quirk_inventory(const Profile& p) {
  std::vector<Quirk> rows = option_quirks(p);
  rows.insert(rows.end(), p.setting_quirks.begin(), p.setting_quirks.end());
  return rows;
}

std::string quirk_reference(const Profile& p, const std::string& name) {
  for (const auto& [key, ref] : p.quirks)
    if (key == name) return ref;
  return p.quirks_checked ? "" : kUndocumented;
}

std::vector<Quirk> option_quirks(const Profile& p) {
  NodeOptions strict = *p.faithful_options;
  make_strict(strict);
  std::vector<Quirk> rows;
  for (const auto& [name, ref] : p.quirks) {
    if (is_setting_key(name)) continue;
    if (find_option(name)) {
      rows.push_back({name, ref, option_text(*p.faithful_options, name), option_text(strict, name)});
      continue;
    }
    for (const OdEntry& e : p.strict_objects)
      if (object_key(e.index, e.sub) == name)
        rows.push_back({name, ref, describe(p.faithful_layout->find(e.index, e.sub)), describe(&e)});
  }
  if (p.quirks_checked) return rows;
  for (const std::string& name : deviating_options(*p.faithful_options))
    rows.push_back({name, kUndocumented, option_text(*p.faithful_options, name), option_text(strict, name)});
  return rows;
}

}  // namespace cansim::config
