#include "model/cia404_profile.hpp"

#include <algorithm>

namespace cansim::model {

namespace {

// CiA 404 analogue-input objects (HYDAC VFL §3.5.3, esd CAN-CBX manuals).
constexpr RoleInfo kRoles[kRoleCount] = {
    {Role::kPv, "pv", 0x6130, true, false, false, kHookRead},
    {Role::kFieldValue, "field_value", 0x6100, true, false, false, kHookRead},
    {Role::kStatus, "status", 0x6150, false, false, false, kHookRead},
    {Role::kUnit, "unit", 0x6131, false, false, false, kHookWrite},
    {Role::kDigits, "digits", 0x6132, false, false, false, kHookWrite},
    {Role::kOffset, "offset", 0x6124, true, true, true, kHookWrite},
    {Role::kAutozero, "autozero", 0x6125, true, false, false, kHookWrite},
    {Role::kDelta, "delta", 0x6133, true, true, true, kHookWrite},
    {Role::kLowerLimit, "lower_limit", 0x6134, true, true, false, kHookWrite},
    {Role::kUpperLimit, "upper_limit", 0x6135, true, true, false, kHookWrite},
    {Role::kHysteresis, "hysteresis", 0x6136, true, true, true, kHookWrite},
    {Role::kSpanStart, "span_start", 0x6148, true, true, false, kHookWrite},
    {Role::kSpanEnd, "span_end", 0x6149, true, true, false, kHookWrite},
    {Role::kFilterType, "filter_type", 0x61A0, false, false, false, kHookWrite},
    {Role::kFilterConstant, "filter_constant", 0x61A1, false, false, false, kHookWrite},
};

}  // namespace

const RoleInfo& role_info(Role r) { return kRoles[std::size_t(r)]; }

const RoleInfo* role_by_name(std::string_view name) {
  for (const RoleInfo& r : kRoles)
    if (name == r.name) return &r;
  return nullptr;
}

const char* role_names() {
  return "pv, field_value, status, unit, digits, offset, autozero, delta, lower_limit, upper_limit, hysteresis, "
         "span_start, span_end, filter_type, filter_constant";
}

bool Param::add_view(const OdEntry* e) {
  if (!e) return true;
  if (count == 4) return false;
  // The REAL view is the primary: it holds the value without rounding.
  if (is_real(e->type) && count && !is_real(views[0]->type)) {
    for (int i = count; i > 0; --i) views[i] = views[i - 1];
    views[0] = e;
  } else {
    views[count] = e;
  }
  ++count;
  return true;
}

std::vector<std::uint8_t> Cia404Builder::discover_subs() const {
  std::vector<std::uint8_t> subs;
  for (std::uint16_t index : {0x6130, 0x7130, 0x9130, 0x6100, 0x7100})
    for (int sub = 1; sub < 255; ++sub)
      if (layout_.find(index, std::uint8_t(sub)) && std::find(subs.begin(), subs.end(), sub) == subs.end())
        subs.push_back(std::uint8_t(sub));
  std::sort(subs.begin(), subs.end());
  return subs;
}

const OdEntry* Cia404Builder::entry(std::uint16_t index, std::uint8_t sub) const {
  const OdEntry* e = layout_.find(index, sub);
  if (!e) {
    const OdObject* o = layout_.object(index);
    if (o && o->kind == ObjectKind::kVar) e = layout_.find(index, 0);
  }
  return e;
}

ChannelConfig Cia404Builder::channel(std::uint8_t sub, std::optional<physics::Channel> quantity) const {
  ChannelConfig c;
  c.sub = sub;
  c.source = physics::Channel::Pressure;
  if (quantity) {
    c.source = *quantity;
  } else if (const OdEntry* e = entry(0x6131, sub); e && e->default_bytes.size() >= 4) {
    if (auto u = builtin_unit(decode_u(DataType::kUnsigned32, e->default_bytes.data()))) c.source = u->kind;
  }
  for (const RoleInfo& r : kRoles) {
    Param& p = c.params[std::size_t(r.role)];
    p.difference = r.difference;
    p.add_view(entry(r.index, sub));
    if (r.twins)
      for (std::uint16_t twin : {0x1000, 0x2000, 0x3000}) p.add_view(entry(std::uint16_t(r.index + twin), sub));
    if (r.valued) c.dependent_roles |= 1u << unsigned(r.role);
  }
  return c;
}

void Cia404Builder::default_units(ChannelConfig& c) {
  static constexpr const char* kPressure[] = {"Pa", "hPa", "kPa", "MPa", "bar", "mbar", "psi"};
  static constexpr const char* kTemperature[] = {"degC", "degF", "K"};
  c.units.clear();
  auto add = [&](const char* name) {
    UnitChoice u;
    u.scale = *named_unit(name, &u.code);
    c.units.push_back(u);
  };
  if (c.source == physics::Channel::Pressure)
    for (const char* n : kPressure) add(n);
  else
    for (const char* n : kTemperature) add(n);
}

void Cia404Builder::choose_fixed_unit(ChannelConfig& c) {
  c.fixed_unit = c.units.front();
  const OdEntry* u = c.param(Role::kUnit).views[0];
  if (!u || u->default_bytes.size() < 4) return;
  const auto code = std::uint32_t(decode_u(u->type, u->default_bytes.data()));
  for (const UnitChoice& choice : c.units)
    if (choice.code == code) c.fixed_unit = choice;
}

std::shared_ptr<Cia404Profile> Cia404Builder::finish() {
  Cia404Profile& out = *out_;
  out.by_slot_.assign(layout_.entries().size(), Cia404Profile::Binding{});
  for (std::size_t ch = 0; ch < out.channels.size(); ++ch) {
    const ChannelConfig& c = out.channels[ch];
    for (std::size_t r = 0; r < kRoleCount; ++r) {
      const Param& p = c.params[r];
      for (int v = 0; v < p.count; ++v) {
        out.by_slot_[p.views[v]->slot] = {std::uint8_t(ch), Role(r), 0};
        if (OdEntry* e = layout_.edit(p.views[v]->index, p.views[v]->sub)) e->hooks |= kRoles[r].hooks;
      }
    }
    for (std::size_t x = 0; x < c.extras.size(); ++x)
      out.by_slot_[c.extras[x].views[0]->slot] = {std::uint8_t(ch), Role::kExtra, std::uint16_t(x)};
  }
  return std::move(out_);
}

std::shared_ptr<Cia404Profile> Cia404Profile::discover(OdLayout& layout, const Cia404Settings& settings) {
  Cia404Builder b(layout);
  b.settings() = settings;
  for (std::uint8_t sub : b.discover_subs()) {
    ChannelConfig c = b.channel(sub);
    Cia404Builder::default_units(c);
    Cia404Builder::choose_fixed_unit(c);
    b.add(std::move(c));
  }
  return b.finish();
}

}  // namespace cansim::model
