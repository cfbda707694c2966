#include "config/vendor_params.hpp"

#include <algorithm>
#include <cmath>

#include "config/physics_config.hpp"

namespace cansim::config {

VendorParams::VendorParams(const std::string& file, const YAML::Node& section, const VendorLayer* over)
    : section_(section), is_map_(section_ && section_.IsMap()), where_{file, "vendor"} {
  if (over && over->section && over->section.IsMap()) {
    over_ = *over;
    has_over_ = true;
  }
}

bool VendorParams::flag(const char* key, bool& out) const {
  if (!has(key)) return false;
  out = get_bool(where(key), node(key));
  return true;
}

void VendorParams::flags(std::initializer_list<std::pair<const char*, bool*>> list) const {
  for (const auto& [key, field] : list) flag(key, *field);
}

bool VendorParams::choice(const char* key, bool& is_first, const char* first, const char* second) const {
  if (!has(key)) return false;
  const std::string word = get_string(where(key), node(key));
  if (word != first && word != second) fail(where(key), node(key), std::string("expected ") + first + " or " + second);
  is_first = word == first;
  return true;
}

bool VendorParams::time_us(const char* key, TimeUs& out, double lo_s, double hi_s, const std::string& range) const {
  if (!has(key)) return false;
  const double t = get_quantity(where(key), node(key), Dim::kTime);
  if (t < lo_s || t > hi_s) fail(where(key), node(key), "expected " + range);
  out = TimeUs(std::llround(t * 1e6));
  if (lo_s > 0) out = std::max<TimeUs>(1, out);
  return true;
}

std::optional<YAML::Node> VendorParams::last_given(const std::string& key) const {
  std::optional<YAML::Node> found;
  if (!has_over_) return found;
  for (const auto& kv : over_.section)
    if (kv.first.Scalar() == key) found = kv.second;
  return found;
}

void VendorParams::reject_unknown_keys() const {
  if (!section_ || section_.IsNull()) return;
  if (!is_map_) fail(where_, section_, "expected a mapping");
  std::vector<std::string> expected{"cia404"};  // parsed by config/cia404_yaml.cpp
  for (const char* k : known_)
    if (std::find(expected.begin(), expected.end(), k) == expected.end()) expected.emplace_back(k);
  for (const auto& kv : section_) {
    const std::string k = kv.first.Scalar();
    if (std::find(expected.begin(), expected.end(), k) != expected.end()) continue;
    std::string list;
    for (const std::string& x : expected) list += (list.empty() ? "" : ", ") + x;
    const std::string message = "unknown key (expected one of: " + list + ")";
    if (overrides(k))
      for (const auto& given : over_.section)
        if (given.first.Scalar() == k) fail(over_.where.child(k), given.first, message);
    fail(where_.child(k), kv.first, message);
  }
}

}  // namespace cansim::config
