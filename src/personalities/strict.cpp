#include "personalities/strict.hpp"

namespace cansim::personalities {

namespace {

// Strict mode's column of the settings tables (model/cia404_settings.hpp).
#define CANSIM_DEVIATION_CIA true
#define CANSIM_DEVIATION_SETTING false

// The one flag strict mode changes in a device's settings.
template <class Settings>
std::vector<model::Quirk> flag_change(const Settings& faithful, const char* name, bool Settings::*flag) {
  Settings strict = faithful;
  make_strict(strict);
  std::vector<model::Quirk> rows;
  auto text = [](bool v) { return std::string(v ? "true" : "false"); };
  if (faithful.*flag != strict.*flag) rows.push_back({name, "", text(faithful.*flag), text(strict.*flag)});
  return rows;
}

}  // namespace

bool is_strict_setting(const std::string& name) {
  static const char* const kNames[] = {
#define CANSIM_STRICT_NAME(kind, key, field, def, strict, help) CANSIM_DEVIATION_##strict ? "cia404." #key : nullptr,
      CANSIM_CIA404_SETTINGS(CANSIM_STRICT_NAME)
#undef CANSIM_STRICT_NAME
          "vendor.autozero_shifts_span",
      "vendor.reset_node_clears_error_register",
  };
  for (const char* n : kNames)
    if (n && name == n) return true;
  return false;
}

// CiA 404 (0x6124 / 0x6125, 0x6131, 0x6150, the CiA 301 abort codes) is what
// the defaults are.
void make_strict(Cia404Settings& s) {
  const Cia404Settings cia;
#define CANSIM_MAKE_STRICT(kind, key, field, def, strict, help) \
  if (CANSIM_DEVIATION_##strict) s.field = cia.field;
  CANSIM_CIA404_SETTINGS(CANSIM_MAKE_STRICT)
#undef CANSIM_MAKE_STRICT
}

void make_strict(dps::Settings& s) { s.autozero_shifts_span = false; }

void make_strict(smc::Settings& s) { s.reset_node_clears_error_register = true; }

std::vector<model::Quirk> strict_changes(const Cia404Settings& faithful) {
  Cia404Settings strict = faithful;
  make_strict(strict);
  std::vector<model::Quirk> rows;
#define CANSIM_STRICT_CHANGE(kind, key, field, def, strict_column, help)                            \
  if (!(faithful.field == strict.field)) {                                                          \
    const auto kind_of = CANSIM_SETTING_KIND_##kind;                                                \
    rows.push_back({"cia404." #key, "", kind_of.text(faithful.field), kind_of.text(strict.field)}); \
  }
  CANSIM_CIA404_SETTINGS(CANSIM_STRICT_CHANGE)
#undef CANSIM_STRICT_CHANGE
  return rows;
}

std::vector<model::Quirk> strict_changes(const dps::Settings& faithful) {
  return flag_change(faithful, "vendor.autozero_shifts_span", &dps::Settings::autozero_shifts_span);
}

std::vector<model::Quirk> strict_changes(const smc::Settings& faithful) {
  return flag_change(faithful, "vendor.reset_node_clears_error_register",
                     &smc::Settings::reset_node_clears_error_register);
}

}  // namespace cansim::personalities
