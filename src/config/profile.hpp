// The YAML profile loader (profiles/*.yaml): one file -> one typed, checked
// model::Profile (identity, bit rate, options, objects, the CiA 404 chain,
// the personality's settings, physics). Nothing above this layer sees YAML.
// See docs/profiles.md.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "config/yaml_util.hpp"
#include "core/node.hpp"
#include "core/node_options.hpp"
#include "core/od.hpp"
#include "model/profile.hpp"

namespace cansim::config {

using Profile = model::Profile;

// Loads a profile file. Throws ConfigError naming file, line and key.
// `strict`: in strict mode whatever the file says (`cansimd --strict`).
Profile load_profile(const std::string& path, bool strict = false);
// Parses a profile from text (tests); `file` is used in error messages.
Profile parse_profile(const std::string& text, const std::string& file = "<string>", bool strict = false);
Profile parse_profile(const YAML::Node& root, const std::string& file, bool strict = false);

// The personality part of a profile: checks the personality's name and
// what it needs (objects, channels), and parses `vendor` (the profile's
// `vendor:` section, or a fleet entry's merge of it), `physics:`, `sensor:`
// and `faults:` of `root` into the typed settings; binds the CiA 404 chain to
// profile.layout. parse_profile() calls it; a fleet entry's variant (own
// layout and options) calls it again.
// `over`: a fleet entry's `vendor:` merged into `vendor`, for its errors' places.
struct VendorLayer;
void parse_personality(Profile& profile, const YAML::Node& root, const YAML::Node& vendor,
                       const VendorLayer* over = nullptr);

// Parses an `objects:` list into a layout (not finalized).
void parse_objects(const Where& w, const YAML::Node& list, OdLayout& out);
// Parses an `options:` map into NodeOptions.
void parse_options(const Where& w, const YAML::Node& map, NodeOptions& out);

// CiA 305 bit-timing table (selector 0): kbit/s <-> index. -1 when not in the table.
int bit_rate_index(std::uint32_t kbit);
std::uint32_t bit_rate_kbit(int index);
// The index as a node holds it: 0xFF for a rate outside the table.
std::uint8_t bit_rate_selector(std::uint32_t kbit);

// What the core needs to build a node of `profile`: its layout, options and
// bit rate, its node-ID unless `node_id` says another, and the serial number
// of the node at `index` of its group when the profile has a
// `serial_number_base` (0x1018:04 = base + index).
NodeSetup node_setup(const Profile& profile, std::optional<std::uint8_t> node_id = std::nullopt,
                     std::uint32_t index = 0);

}  // namespace cansim::config
