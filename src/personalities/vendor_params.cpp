#include "personalities/vendor_params.hpp"

#include <algorithm>
#include <cmath>

#include "config/physics_config.hpp"

namespace cansim::personalities {

VendorParams::VendorParams(const config::Profile& profile)
    : section_(profile.personality_params),
      is_map_(section_ && section_.IsMap()),
      where_{profile.file, "vendor"} {}

bool VendorParams::flag(const char* key, bool& out) const {
  if (!has(key)) return false;
  out = config::get_bool(where(key), node(key));
  return true;
}

void VendorParams::flags(std::initializer_list<std::pair<const char*, bool*>> list) const {
  for (const auto& [key, field] : list) flag(key, *field);
}

bool VendorParams::choice(const char* key, bool& is_first, const char* first, const char* second) const {
  if (!has(key)) return false;
  const std::string word = config::get_string(where(key), node(key));
  if (word != first && word != second) config::fail(where(key), node(key), std::string("expected ") + first + " or " + second);
  is_first = word == first;
  return true;
}

bool VendorParams::time_us(const char* key, TimeUs& out, double lo_s, double hi_s, const std::string& range) const {
  if (!has(key)) return false;
  const double t = config::get_quantity(where(key), node(key), config::Dim::kTime);
  if (t < lo_s || t > hi_s) config::fail(where(key), node(key), "expected " + range);
  out = TimeUs(std::llround(t * 1e6));
  if (lo_s > 0) out = std::max<TimeUs>(1, out);
  return true;
}

void VendorParams::reject_unknown_keys() const {
  if (!section_ || section_.IsNull()) return;
  if (!is_map_) config::fail(where_, section_, "expected a mapping");
  const auto known = [&](const std::string& k) {
    return k == "cia404" || k == "serial_number_base" ||
           std::any_of(known_.begin(), known_.end(), [&](const char* x) { return k == x; });
  };
  for (const auto& kv : section_) {
    const std::string k = kv.first.Scalar();
    if (known(k)) continue;
    std::string list = "cia404, serial_number_base";
    for (const char* x : known_) list += std::string(", ") + x;
    config::fail(where_.child(k), kv.first, "unknown key (expected one of: " + list + ")");
  }
}

}  // namespace cansim::personalities
