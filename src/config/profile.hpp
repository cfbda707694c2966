// A node profile (profiles/*.yaml): identity, bit rate, options (quirks), the
// object dictionary as data, and the raw sections that the personality and
// physics layers read themselves. See README "Profile reference".
#pragma once

#include <yaml-cpp/yaml.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "config/yaml_util.hpp"
#include "core/node_options.hpp"
#include "core/od.hpp"

namespace cansim::config {

struct Profile {
  std::string file;                        // where it was loaded from
  std::string name;
  std::string description;
  std::string personality = "generic";     // behaviour module
  std::uint8_t node_id = 1;                // default node-ID (0xFF = LSS-unconfigured)
  std::uint32_t bit_rate_kbit = 250;       // default bit rate
  std::shared_ptr<OdLayout> layout;        // finalized; hooks may still be set by personalities
  std::shared_ptr<NodeOptions> options;    // in effect: faithful or strict, then overrides
  // Strict mode (config/strict_mode.hpp): the profile as written, the
  // entries strict mode replaces or adds, the manual reference per deviation.
  bool strict = false;
  std::shared_ptr<const NodeOptions> faithful_options;
  std::shared_ptr<const OdLayout> faithful_layout;
  std::vector<OdEntry> strict_objects;
  std::vector<std::pair<std::string, std::string>> quirks;  // name -> manual reference
  bool quirks_checked = false;             // has a `quirks:` map (checked against the deviations)
  YAML::Node option_overrides;             // a fleet entry's `options:`
  Where option_overrides_where;
  YAML::Node personality_params;           // `vendor:` section, read by the personality
  YAML::Node physics;                      // `physics:` section, read by the physics layer
  YAML::Node sensor;                       // `sensor:` section
  YAML::Node faults;                       // `faults:` section
  YAML::Node root;                         // the whole document
  std::shared_ptr<const void> prepared;    // set by personalities::prepare_profile
};

// Loads a profile file. Throws ConfigError naming file, line and key.
Profile load_profile(const std::string& path);
// Parses a profile from text (tests); `file` is used in error messages.
Profile parse_profile(const std::string& text, const std::string& file = "<string>");
Profile parse_profile(const YAML::Node& root, const std::string& file);

// Parses an `objects:` list into a layout (not finalized).
void parse_objects(const Where& w, const YAML::Node& list, OdLayout& out);
// Parses an `options:` map into NodeOptions.
void parse_options(const Where& w, const YAML::Node& map, NodeOptions& out);

// CiA 305 bit-timing table (selector 0): kbit/s <-> index. -1 when not in the table.
int bit_rate_index(std::uint32_t kbit);
std::uint32_t bit_rate_kbit(int index);

}  // namespace cansim::config
