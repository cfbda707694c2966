// Strict mode and the quirk inventory of a profile (docs/profiles.md "Strict mode and
// quirks"). A profile's `options:` and `objects:` are its faithful mode;
// strict mode sets every option node_options.hpp marks CIA(v) to v and
// applies the profile's `strict_objects:` (OD entries that are the manual's
// quirk, not the device's identity). Option overrides of a fleet entry are
// applied last, so they win over both modes.
//
// Strict mode is decided while loading (a profile is loaded once per mode):
// `strict: true` in the profile or on a fleet entry, or `cansimd --strict`
// (load_profile / load_fleet with strict). A fleet entry's `options:` apply
// after it, so they win over both modes.
//
// `quirks:` maps each deviation the faithful profile has to the manual page
// or table that documents it. Keys: an option name, `object 0xIIII:SS` for a
// strict_objects entry, `cia404.<setting>` / `vendor.<setting>` for chain and
// device settings (checked by parse_personality). A profile
// without `quirks:` (tests, experiments) is not checked: its deviations are
// listed as undocumented.
#pragma once

#include <string>
#include <vector>

#include "config/profile.hpp"

namespace cansim::config {

using Quirk = model::Quirk;

// The reference of a deviation in a profile without `quirks:` map.
inline constexpr const char* kUndocumented = "(undocumented: the profile has no quirks map)";

// Reads `strict:`, `quirks:` and `strict_objects:` of a profile whose
// options and layout are parsed; checks that `quirks:` names exactly the
// deviating options and the strict_objects entries; applies strict mode
// when the profile or `force_strict` asks for it. Throws ConfigError.
void parse_strict_sections(const Where& w, const YAML::Node& root, Profile& p, bool force_strict = false);

// Rebuilds options and layout from the faithful ones for p.strict, then
// applies `overrides` (a fleet entry's `options:`, may be undefined); a
// private layout either way (the chain sets hooks on it). The personality
// part must be parsed again afterwards (parse_personality).
void apply_mode(Profile& p, const Where& w, const YAML::Node& overrides);

// Strict mode of the chain and device settings: records what it changes in
// p.setting_quirks (with the `quirks:` references, a missing one is an error
// at `quirks`) and applies it when p.strict. Called by parse_personality.
void apply_setting_strictness(Profile& p, model::Cia404Settings& chain, const YAML::Node& root);

// Every deviation of the profile: options, objects, chain and device settings.
std::vector<Quirk> quirk_inventory(const Profile& p);

// The option and object rows of the inventory, in `quirks:` order.
std::vector<Quirk> option_quirks(const Profile& p);
// The manual reference of a `quirks:` key (empty: none).
std::string quirk_reference(const Profile& p, const std::string& name);

}  // namespace cansim::config
