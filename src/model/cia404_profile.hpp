// The CiA 404 measurement chain as profile data: which OD entries serve
// which role of which channel, the accepted units, and the chain settings.
// Built once per profile against its OdLayout (whose entries it points to
// and marks with the hooks the chain needs) and shared by all its nodes.
//
// A loader (config/: YAML `vendor: cia404:`, an EDS's CiA 404 objects) fills
// it through Cia404Builder; the chain (personalities/cia404.hpp) only reads it.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "core/can_frame.hpp"
#include "core/node_options.hpp"
#include "core/od.hpp"
#include "core/sdo_abort.hpp"
#include "model/cia404_settings.hpp"
#include "model/units.hpp"
#include "physics/sensor.hpp"

namespace cansim::model {

// What an OD entry is to the chain.
enum class Role : std::uint8_t {
  kPv,              // 0x6130 / 0x7130 / 0x9130 (live)
  kFieldValue,      // 0x6100 / 0x7100 / 0x9100 raw ADC counts (live)
  kStatus,          // 0x6150 (live)
  kUnit,            // 0x6131
  kDigits,          // 0x6132
  kOffset,          // 0x6124 (+ twins)
  kAutozero,        // 0x6125 / 0x7125
  kDelta,           // 0x6133
  kLowerLimit,      // 0x6134
  kUpperLimit,      // 0x6135
  kHysteresis,      // 0x6136
  kSpanStart,       // 0x6148
  kSpanEnd,         // 0x6149
  kFilterType,      // 0x61A0
  kFilterConstant,  // 0x61A1
  kExtra,           // a profile-listed object that follows unit changes (e.g. DPS 0x2006)
  kNone,
};
constexpr std::size_t kRoleCount = std::size_t(Role::kExtra);

struct RoleInfo {
  Role role;
  const char* name;     // as profiles name it: "pv", "lower_limit", ...
  std::uint16_t index;  // CiA 404 REAL32 / base index
  bool twins;           // 0x71xx / 0x81xx / 0x91xx integer twins may exist
  bool valued;          // a logical value that follows unit / digits changes
  bool difference;      // converts without zero shift
  std::uint8_t hooks;   // kHookRead / kHookWrite the chain needs on its entries
};
const RoleInfo& role_info(Role r);
inline bool is_valued(Role r) { return r < Role::kExtra && role_info(r).valued; }
const RoleInfo* role_by_name(std::string_view name);  // null: no such role
// "pv, field_value, status, ..." for error messages.
const char* role_names();

// One logical value of a channel and its OD views; views[0] is the primary
// (the REAL32 view when there is one).
struct Param {
  const OdEntry* views[4] = {};
  std::uint8_t count = 0;
  bool difference = false;  // converted without zero shift on a unit change

  bool present() const { return count != 0; }
  // Adds a view (the REAL one becomes the primary); false when four are there.
  bool add_view(const OdEntry* e);
};

struct UnitChoice {
  std::uint32_t code = 0;
  UnitScale scale;
  int max_digits = -1;  // largest 0x6132 allowed with this unit (-1: OD limits only)
  // User-scaled unit: one unit = (value of this REAL32 object) x `scale`,
  // latched when the unit is selected (e.g. Gems 0x2032 "non-SI" pressure).
  const OdEntry* scale_object = nullptr;
};

struct ChannelConfig {
  std::uint8_t sub = 1;
  physics::Channel source = physics::Channel::Pressure;  // what it measures; its units are of this quantity
  Param params[kRoleCount];
  std::vector<Param> extras;          // profile-listed unit-dependent objects
  std::uint32_t dependent_roles = 0;  // bit per Role converted on a unit change
  std::vector<UnitChoice> units;      // accepted 0x6131 values
  UnitChoice fixed_unit;              // unit when 0x6131 is absent
  // Holds the autozero correction in fixed_unit (persisted like any entry);
  // null: the correction lives in RAM until the next reset node.
  const OdEntry* zero_object = nullptr;
  const Param& param(Role r) const { return params[std::size_t(r)]; }
};

// The chain's view of a profile.
class Cia404Profile {
 public:
  struct Binding {
    std::uint8_t channel = 0xFF;
    Role role = Role::kNone;
    std::uint16_t extra = 0;  // index into extras for Role::kExtra
  };
  const Binding& binding(const OdEntry& e) const { return by_slot_[e.slot]; }

  std::vector<ChannelConfig> channels;
  Cia404Settings settings;

  // The chain with every channel the layout has (the sub-indices of the PV
  // and field-value objects), CiA 404 defaults: what a profile without
  // `vendor: cia404: channels:` or an EDS gets.
  static std::shared_ptr<Cia404Profile> discover(OdLayout& layout, const Cia404Settings& settings = {});

 private:
  std::vector<Binding> by_slot_;
  friend class Cia404Builder;
};

// Builds a Cia404Profile against a layout. A loader starts each channel with
// channel(), edits it (views, units, dependents) and adds it; finish() binds
// the entries (sets their hooks).
class Cia404Builder {
 public:
  explicit Cia404Builder(OdLayout& layout) : layout_(layout), out_(std::make_shared<Cia404Profile>()) {}

  Cia404Settings& settings() { return out_->settings; }
  // The sub-indices of the PV / field-value objects, ascending.
  std::vector<std::uint8_t> discover_subs() const;
  // The entry of `index` for channel `sub`; a VAR object serves a
  // single-channel device. Null when there is none.
  const OdEntry* entry(std::uint16_t index, std::uint8_t sub) const;
  // A channel with the CiA 404 views of `sub` and every valued role unit
  // dependent; its quantity from the default of 0x6131 (pressure without one).
  ChannelConfig channel(std::uint8_t sub, std::optional<physics::Channel> quantity = std::nullopt) const;
  // The units a channel of this kind accepts by default.
  static void default_units(ChannelConfig& c);
  // fixed_unit = the unit matching 0x6131's default, else the first unit.
  static void choose_fixed_unit(ChannelConfig& c);
  void add(ChannelConfig c) { out_->channels.push_back(std::move(c)); }
  const std::vector<ChannelConfig>& channels() const { return out_->channels; }
  std::shared_ptr<Cia404Profile> finish();

 private:
  OdLayout& layout_;
  std::shared_ptr<Cia404Profile> out_;
};

}  // namespace cansim::model
