// A personality's own keys of the profile's `vendor:` section, each
// named once: the keys a personality reads are the keys it accepts. Each
// getter leaves `out` as it is when the key is absent (or the section is not
// a mapping) and says whether it was given; a bad value throws
// config::ConfigError naming file:line:column: vendor.<key> and what was
// expected, like every profile error. reject_unknown_keys() comes last.
//
//   VendorParams v(file, root["vendor"]);
//   v.integer("serial_part3", s.serial_part3, 0, 9999);
//   v.flags({{"overload_counters", &s.overload_counters}, {"boot_emcys", &s.boot_emcys}});
//   v.time_us("monitor_period", s.monitor_period_us, 1e-3, 10.0, "1 ms .. 10 s");
//   v.reject_unknown_keys();
#pragma once

#include <cstdint>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "config/yaml_util.hpp"
#include "core/can_frame.hpp"

namespace cansim::config {

// A fleet entry's `vendor:` over its profile's (config/fleet.cpp): the keys
// it gives are reported where the entry writes them (fleet file, line,
// column, nodes[i].vendor.<key>).
struct VendorLayer {
  Where where;         // {fleet file, "nodes[i].vendor"}
  YAML::Node section;  // the entry's `vendor:` mapping, with its marks
};

class VendorParams {
 public:
  static constexpr double kPositive = std::numeric_limits<double>::denorm_min();  // lo_s: any time > 0
  static constexpr double kForever = std::numeric_limits<double>::infinity();

  // `section` is the profile's `vendor:` node (may be undefined); with
  // `over`, the merge of the profile's and the entry's (`over` wins a key).
  VendorParams(const std::string& file, const YAML::Node& section, const VendorLayer* over = nullptr);

  bool has(const char* key) const {
    known_.push_back(key);
    return is_map_ && section_[key];
  }
  YAML::Node node(const char* key) const {
    if (auto given = last_given(key)) return *given;
    return is_map_ ? section_[key] : YAML::Node();
  }
  Where where(const char* key) const { return overrides(key) ? over_.where.child(key) : where_.child(key); }

  bool flag(const char* key, bool& out) const;
  void flags(std::initializer_list<std::pair<const char*, bool*>> list) const;
  // An integer in lo..hi stored into T (uint8_t, uint16_t, uint32_t, ...).
  template <class T>
  bool integer(const char* key, T& out, std::int64_t lo, std::int64_t hi) const {
    if (!has(key)) return false;
    out = T(config::get_int(where(key), node(key), lo, hi));
    return true;
  }
  // One of two words ("expected manual or cia301"); true when it is `first`.
  bool choice(const char* key, bool& is_first, const char* first, const char* second) const;
  // A time ("10 ms") in whole microseconds (rounded), lo_s..hi_s seconds, else
  // "expected <range>". With lo_s > 0 the result is at least 1 us.
  bool time_us(const char* key, TimeUs& out, double lo_s, double hi_s, const std::string& range) const;
  // Fails on a `vendor:` that is not a mapping, and on a key other than
  // `cia404` that no getter asked for, listing the keys it expected.
  void reject_unknown_keys() const;

 private:
  bool overrides(const std::string& key) const { return last_given(key).has_value(); }
  // The entry's value of `key`, the last where it is repeated (as the merge
  // took it); none when the entry does not give it.
  std::optional<YAML::Node> last_given(const std::string& key) const;

  const YAML::Node section_;
  const bool is_map_;
  Where where_;
  VendorLayer over_;
  bool has_over_ = false;
  mutable std::vector<const char*> known_;  // the keys asked for, in order
};

}  // namespace cansim::config
