#include "config/cia404_yaml.hpp"

#include <cmath>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "config/physics_config.hpp"

namespace cansim::config {

namespace {

using model::ChannelConfig;
using model::Cia404Builder;
using model::Cia404Settings;
using model::Param;
using model::RoleInfo;
using model::UnitChoice;

// One chain setting's value as its kind declares it (model/cia404_settings.hpp):
// a value the kind refuses fails with what it expected.
template <class Kind>
void parse_setting(const Where& w, const YAML::Node& n, const Kind& kind, typename Kind::Value& out) {
  if constexpr (std::is_same_v<Kind, option_kind::Time>) {
    const double secs = get_quantity(w, n, Dim::kTime);
    if (secs < 0) fail(w, n, kind.expected());
    out = TimeUs(std::llround(secs * 1e6));
  } else if constexpr (std::is_same_v<Kind, option_kind::Bool>) {
    out = get_bool(w, n);
  } else if constexpr (requires { kind.parse(std::string_view(), out); }) {
    if (!n.IsScalar() || !kind.parse(n.Scalar(), out)) fail(w, n, kind.expected());
  } else {  // Code32
    out = typename Kind::Value(std::uint32_t(get_int(w, n, 0, 0xFFFFFFFF)));
  }
}

// The keys of `vendor: cia404:`: the settings and the channel list.
void check_cia404_keys(const Where& w, const YAML::Node& section) {
  static const std::vector<const char*> kKeys = {
#define CANSIM_SETTING_KEY(kind, key, field, def, strict, help) #key,
      CANSIM_CIA404_SETTINGS(CANSIM_SETTING_KEY)
#undef CANSIM_SETTING_KEY
          "channels"};
  for (const auto& kv : section) check_key(w, kv.first, kKeys);
}

void parse_settings(const Where& w, const YAML::Node& section, Cia404Settings& s) {
  check_cia404_keys(w, section);
#define CANSIM_PARSE_SETTING(kind, key, field, def, strict, help) \
  if (section[#key]) parse_setting(w.child(#key), section[#key], CANSIM_SETTING_KIND_##kind, s.field);
  CANSIM_CIA404_SETTINGS(CANSIM_PARSE_SETTING)
#undef CANSIM_PARSE_SETTING
}

// One entry of `channels:`.
struct ChannelParser {
  const Cia404Builder& b;
  OdLayout& layout;
  std::uint8_t sub;

  std::uint16_t index_of(const Where& wi, const YAML::Node& n) const {
    return std::uint16_t(get_int(wi, n, 0x1000, 0xFFFF));
  }
  std::string no_object() const { return "no such object for channel " + std::to_string(sub); }

  void objects(const Where& wo, const YAML::Node& m, ChannelConfig& c) const {
    if (!m.IsMap()) fail(wo, m, "expected a mapping of role names to OD indices");
    for (const auto& kv : m) {
      const std::string name = kv.first.Scalar();
      const Where wr = wo.child(name);
      const RoleInfo* r = model::role_by_name(name);
      if (!r) fail(wr, kv.first, std::string("unknown role (expected ") + model::role_names() + ")");
      Param& p = c.params[std::size_t(r->role)];
      p = Param{};
      p.difference = r->difference;
      YAML::Node list = kv.second;
      if (list.IsScalar()) {
        YAML::Node seq(YAML::NodeType::Sequence);
        seq.push_back(list);
        list = seq;
      }
      if (!list.IsSequence()) fail(wr, kv.second, "expected an index or a list of indices");
      for (std::size_t i = 0; i < list.size(); ++i) {
        const Where wi = list.size() == 1 && kv.second.IsScalar() ? wr : wr.item(i);
        const OdEntry* e = b.entry(index_of(wi, list[i]), sub);
        if (!e) fail(wi, list[i], no_object() + " in the objects list");
        if (!p.add_view(e)) fail(wi, list[i], "at most four views (REAL32 and three integer twins)");
      }
    }
  }

  UnitChoice unit(const Where& wi, const YAML::Node& n, physics::Channel kind) const {
    UnitChoice u;
    std::string name;
    if (n.IsScalar()) {
      name = n.Scalar();
    } else {
      check_keys(wi, n, {"unit", "code", "max_digits", "scale_object"});
      if (!n["unit"]) fail(wi.child("unit"), n, "missing required key 'unit'");
      name = get_string(wi.child("unit"), n["unit"]);
      if (n["max_digits"]) u.max_digits = int(get_int(wi.child("max_digits"), n["max_digits"], 0, 18));
    }
    const YAML::Node& at = n.IsScalar() ? n : n["unit"];
    const Where wn = n.IsScalar() ? wi : wi.child("unit");
    auto scale = model::named_unit(name, &u.code);
    if (!scale) fail(wn, at, "unknown unit (expected Pa, hPa, kPa, MPa, bar, mbar, psi, atm, at, mmHg, degC, degF, K)");
    if (scale->kind != kind) fail(wn, at, "unit of the wrong quantity for this channel");
    u.scale = *scale;
    if (!n.IsScalar() && n["code"]) u.code = std::uint32_t(get_int(wi.child("code"), n["code"], 0, 0xFFFFFFFF));
    if (!n.IsScalar() && n["scale_object"]) {
      u.scale_object = layout.find(index_of(wi.child("scale_object"), n["scale_object"]), 0);
      if (!u.scale_object || !is_real(u.scale_object->type))
        fail(wi.child("scale_object"), n["scale_object"], "expected the index of a REAL32 / REAL64 VAR object");
    }
    if (u.code == 0) fail(wi, n, "this unit has no CiA 303-2 code built in: give 'code'");
    return u;
  }

  void units(const Where& wu, const YAML::Node& list, ChannelConfig& c) const {
    if (!list.IsSequence() || list.size() == 0) fail(wu, list, "expected a list of units");
    c.units.clear();
    for (std::size_t i = 0; i < list.size(); ++i) c.units.push_back(unit(wu.item(i), list[i], c.source));
  }

  void dependents(const Where& wd, const YAML::Node& list, ChannelConfig& c) const {
    if (!list.IsSequence()) fail(wd, list, "expected a list of roles or OD indices");
    c.dependent_roles = 0;
    for (std::size_t i = 0; i < list.size(); ++i) {
      const Where wi = wd.item(i);
      const YAML::Node& n = list[i];
      bool difference = false;
      if (n.IsMap()) {
        check_keys(wi, n, {"index", "difference"});
        if (!n["index"]) fail(wi.child("index"), n, "missing required key 'index'");
        if (n["difference"]) difference = get_bool(wi.child("difference"), n["difference"]);
      } else if (const RoleInfo* r = model::role_by_name(n.Scalar())) {
        if (!r->valued) fail(wi, n, "this role has no unit-dependent value");
        c.dependent_roles |= 1u << unsigned(r->role);
        continue;
      }
      // Not assigned after construction: yaml-cpp's operator= would overwrite the aliased list item.
      const YAML::Node idx = n.IsMap() ? n["index"] : n;
      std::int64_t index = 0;
      if (!idx.IsScalar() || !parse_int_literal(idx.Scalar(), index) || index < 0x1000 || index > 0xFFFF)
        fail(wi, idx,
             "expected a role name (offset, delta, lower_limit, upper_limit, hysteresis, span_start, span_end) or an "
             "OD index");
      const OdEntry* e = b.entry(std::uint16_t(index), sub);
      if (!e) fail(wi, idx, no_object());
      if (is_variable_size(e->type)) fail(wi, idx, "expected a numeric object");
      Param p;
      p.difference = difference;
      p.add_view(e);
      c.extras.push_back(p);
    }
  }

  const OdEntry* zero_object(const Where& wz, const YAML::Node& n) const {
    if (!n.IsMap() || !n["index"]) fail(wz, n, "expected {index: <OD index>, sub: <sub-index>}");
    check_keys(wz, n, {"index", "sub"});
    const std::uint16_t index = index_of(wz.child("index"), n["index"]);
    const auto zsub = std::uint8_t(n["sub"] ? get_int(wz.child("sub"), n["sub"], 0, 254) : 0);
    const OdEntry* e = layout.find(index, zsub);
    if (!e || !is_real(e->type)) fail(wz, n, "expected a REAL32 / REAL64 entry");
    return e;
  }

  ChannelConfig parse(const Where& wc, const YAML::Node& m) const {
    std::optional<physics::Channel> quantity;
    if (m["quantity"]) {
      quantity = physics::parse_channel(get_string(wc.child("quantity"), m["quantity"]));
      if (!quantity) fail(wc.child("quantity"), m["quantity"], "expected pressure or temperature");
    }
    ChannelConfig c = b.channel(sub, quantity);
    if (m["objects"]) objects(wc.child("objects"), m["objects"], c);
    if (m["units"]) units(wc.child("units"), m["units"], c);
    else Cia404Builder::default_units(c);
    Cia404Builder::choose_fixed_unit(c);
    if (m["fixed_unit"]) {
      const std::string name = get_string(wc.child("fixed_unit"), m["fixed_unit"]);
      auto s = model::named_unit(name, &c.fixed_unit.code);
      if (!s || s->kind != c.source)
        fail(wc.child("fixed_unit"), m["fixed_unit"], "expected a unit of this channel's quantity");
      c.fixed_unit.scale = *s;
    }
    if (m["unit_dependent"]) dependents(wc.child("unit_dependent"), m["unit_dependent"], c);
    if (m["zero_correction"]) c.zero_object = zero_object(wc.child("zero_correction"), m["zero_correction"]);
    return c;
  }
};

void parse_channels(const Where& wl, const YAML::Node& list, OdLayout& layout, Cia404Builder& b) {
  if (!list.IsSequence()) fail(wl, list, "expected a list of channels");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const Where wi = wl.item(i);
    check_keys(wi, list[i], {"sub", "quantity", "objects", "units", "fixed_unit", "unit_dependent", "zero_correction"});
    if (!list[i]["sub"]) fail(wi.child("sub"), list[i], "missing required key 'sub'");
    const auto sub = std::uint8_t(get_int(wi.child("sub"), list[i]["sub"], 1, 254));
    for (const ChannelConfig& other : b.channels())
      if (other.sub == sub) fail(wi.child("sub"), list[i]["sub"], "duplicate channel");
    b.add(ChannelParser{b, layout, sub}.parse(wi, list[i]));
  }
}

}  // namespace

std::shared_ptr<model::Cia404Profile> parse_cia404(const Where& w, const YAML::Node& section, OdLayout& layout) {
  const bool given = section && !section.IsNull();
  if (given && !section.IsMap()) fail(w, section, "expected a mapping");
  if (!given || !section["channels"]) {
    Cia404Settings s;
    if (given) parse_settings(w, section, s);
    return model::Cia404Profile::discover(layout, s);
  }
  Cia404Builder b(layout);
  parse_settings(w, section, b.settings());
  parse_channels(w.child("channels"), section["channels"], layout, b);
  return b.finish();
}

}  // namespace cansim::config
