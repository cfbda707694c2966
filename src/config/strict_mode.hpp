// Strict mode and the quirk inventory of a profile (README "Strict mode and
// quirks"). A profile's `options:` and `objects:` are its faithful mode;
// strict mode sets every option node_options.hpp marks CIA(v) to v and
// applies the profile's `strict_objects:` (OD entries that are the manual's
// quirk, not the device's identity). Option overrides of a fleet entry are
// applied last, so they win over both modes.
//
// `quirks:` maps each deviation the faithful profile has to the manual page
// or table that documents it. Keys: an option name, `object 0xIIII:SS` for a
// strict_objects entry, `cia404.<setting>` / `vendor.<setting>` for chain and
// device settings (checked by personalities::prepare_profile). A profile
// without `quirks:` (tests, experiments) is not checked: its deviations are
// listed as undocumented.
#pragma once

#include <string>
#include <vector>

#include "config/profile.hpp"

namespace cansim::config {

// One deviation of faithful mode from CiA.
struct Quirk {
  std::string name;       // option, "object 0x1003:00", "cia404.bad_unit_abort"
  std::string reference;  // the manual's page / table
  std::string faithful;   // value in faithful mode
  std::string strict;     // value in strict mode
};

// The reference of a deviation in a profile without `quirks:` map.
inline constexpr const char* kUndocumented = "(undocumented: the profile has no quirks map)";

// Reads `strict:`, `quirks:` and `strict_objects:` of a profile whose
// options and layout are parsed; checks that `quirks:` names exactly the
// deviating options and the strict_objects entries; applies strict mode
// when the profile asks for it. Throws ConfigError.
void parse_strict_sections(const Where& w, const YAML::Node& root, Profile& p);

// A fleet entry's `options:` overrides (kept, so that a later switch to
// strict mode still applies them last).
void set_option_overrides(Profile& p, const Where& w, const YAML::Node& overrides);
// Rebuilds options and layout from the faithful ones for p.strict (a private
// layout either way: personalities set hooks on it).
void apply_mode(Profile& p);
// `cansimd --strict`: every profile of the fleet in strict mode.
void make_fleet_strict(std::vector<std::shared_ptr<Profile>>& profiles);

// The option and object rows of the inventory, in `quirks:` order.
std::vector<Quirk> option_quirks(const Profile& p);
// The manual reference of a `quirks:` key (empty: none).
std::string quirk_reference(const Profile& p, const std::string& name);

}  // namespace cansim::config
