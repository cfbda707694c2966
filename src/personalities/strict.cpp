#include "personalities/strict.hpp"

#include <cstdio>

namespace cansim::personalities {

namespace {

std::string text_of(bool v) { return v ? "true" : "false"; }
std::string text_of(const std::string& v) { return v; }
std::string text_of(SdoAbort a) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08X", unsigned(a));
  return buf;
}
std::string text_of(DigitsOnUnitChange d) {
  switch (d) {
    case DigitsOnUnitChange::kKeep: return "keep";
    case DigitsOnUnitChange::kReject: return "reject";
    case DigitsOnUnitChange::kClamp: return "clamp";
    case DigitsOnUnitChange::kAdjust: return "adjust";
  }
  return "?";
}

template <class T>
void add_if_changed(std::vector<model::Quirk>& rows, const char* name, const T& faithful, const T& strict) {
  if (!(faithful == strict)) rows.push_back({name, "", text_of(faithful), text_of(strict)});
}

}  // namespace

bool is_strict_setting(const std::string& name) {
  static const char* const kNames[] = {
      "cia404.digits_on_unit_change", "cia404.autozero_target", "cia404.unit_informational",
      "cia404.span_compare",          "cia404.bad_unit_abort",  "cia404.bad_autozero_abort",
      "cia404.digits_abort",          "cia404.unit_digits_abort", "cia404.negative_abort",
      "vendor.autozero_shifts_span",  "vendor.reset_node_clears_error_register",
  };
  for (const char* n : kNames)
    if (name == n) return true;
  return false;
}

void make_strict(Cia404Settings& s) {
  const Cia404Settings cia;
  s.digits_on_unit_change = cia.digits_on_unit_change;
  s.autozero_to_correction = cia.autozero_to_correction;  // CiA 404 0x6125: 'zero' sets the offset 0x6124
  s.unit_informational = cia.unit_informational;          // 0x6131: the PV is in the selected unit
  s.span_compares_input = cia.span_compares_input;        // 0x6150 judges the PV against 0x6148 / 0x6149
  s.bad_unit_abort = cia.bad_unit_abort;
  s.bad_autozero_abort = cia.bad_autozero_abort;
  s.digits_abort = cia.digits_abort;
  s.unit_digits_abort = cia.unit_digits_abort;
  s.negative_abort = cia.negative_abort;
}

void make_strict(dps::Settings& s) { s.autozero_shifts_span = false; }

void make_strict(smc::Settings& s) { s.reset_node_clears_error_register = true; }

std::vector<model::Quirk> strict_changes(const Cia404Settings& faithful) {
  Cia404Settings strict = faithful;
  make_strict(strict);
  std::vector<model::Quirk> rows;
  add_if_changed(rows, "cia404.digits_on_unit_change", faithful.digits_on_unit_change, strict.digits_on_unit_change);
  auto target = [](bool correction) { return std::string(correction ? "correction" : "offset"); };
  add_if_changed(rows, "cia404.autozero_target", target(faithful.autozero_to_correction),
                 target(strict.autozero_to_correction));
  add_if_changed(rows, "cia404.unit_informational", faithful.unit_informational, strict.unit_informational);
  auto compare = [](bool input) { return std::string(input ? "input" : "pv"); };
  add_if_changed(rows, "cia404.span_compare", compare(faithful.span_compares_input), compare(strict.span_compares_input));
  add_if_changed(rows, "cia404.bad_unit_abort", faithful.bad_unit_abort, strict.bad_unit_abort);
  add_if_changed(rows, "cia404.bad_autozero_abort", faithful.bad_autozero_abort, strict.bad_autozero_abort);
  add_if_changed(rows, "cia404.digits_abort", faithful.digits_abort, strict.digits_abort);
  add_if_changed(rows, "cia404.unit_digits_abort", faithful.unit_digits_abort, strict.unit_digits_abort);
  add_if_changed(rows, "cia404.negative_abort", faithful.negative_abort, strict.negative_abort);
  return rows;
}

namespace {

// The one flag strict mode changes in a device's settings.
template <class Settings>
std::vector<model::Quirk> flag_change(const Settings& faithful, const char* name, bool Settings::*flag) {
  Settings strict = faithful;
  make_strict(strict);
  std::vector<model::Quirk> rows;
  add_if_changed(rows, name, faithful.*flag, strict.*flag);
  return rows;
}

}  // namespace

std::vector<model::Quirk> strict_changes(const dps::Settings& faithful) {
  return flag_change(faithful, "vendor.autozero_shifts_span", &dps::Settings::autozero_shifts_span);
}

std::vector<model::Quirk> strict_changes(const smc::Settings& faithful) {
  return flag_change(faithful, "vendor.reset_node_clears_error_register",
                     &smc::Settings::reset_node_clears_error_register);
}

}  // namespace cansim::personalities
