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

}  // namespace cansim::personalities
