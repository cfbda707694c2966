// The CiA 404 chain's settings (a profile's `vendor: cia404:`), declared once
// as the node options are (core/node_options.hpp): one line
// X(KIND, key, field, default, strict, "help") gives the Cia404Settings
// member, the YAML key the loader parses (config/cia404_yaml.cpp: a value
// outside the kind fails with file:line:column and what was expected) and
// what strict mode does with it (personalities/strict.cpp). The defaults
// are CiA 404 behaviour. Kinds:
//   TIME          a time >= 0 ("10 ms"), in microseconds
//   BOOL          true / false
//   CHOICE(a, b)  one of two words: false = a, true = b
//   ENUM(Type)    one of the names of EnumNames<Type>
//   BYTES         a set of values 0..255 as ranges "254-255"
//   CODE32        a 32-bit code (a signature)
//   ABORT         an SDO abort code
// Strict:
//   CIA      a vendor deviation: strict mode sets the default (a profile that
//            sets anything else lists `cia404.<key>` under `quirks:`);
//   SETTING  a conformant choice: strict mode keeps the profile's value.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

#include "core/can_frame.hpp"
#include "core/node_options.hpp"
#include "core/sdo_abort.hpp"

namespace cansim {

namespace model {
// What the chain does with 0x6132 when 0x6131 changes.
enum class DigitsOnUnitChange : std::uint8_t { kKeep, kReject, kClamp, kAdjust };
// CiA 404 0x61A0 values (the chain's input filter).
enum class FilterTypeCode : std::uint8_t { kNone, kMovingAverage, kRepeatingAverage };
}  // namespace model

template <>
struct EnumNames<model::DigitsOnUnitChange> {
  static constexpr std::array<std::string_view, 4> names = {"keep", "reject", "clamp", "adjust"};
};
template <>
struct EnumNames<model::FilterTypeCode> {
  static constexpr std::array<std::string_view, 3> names = {"none", "moving_average", "repeating_average"};
};

// ---- the kinds of the chain settings besides the node options' (option_kind)
namespace option_kind {
struct Time {  // the loader parses it as a YAML quantity
  using Value = TimeUs;
  std::string expected() const { return "expected a time >= 0"; }
  std::string text(Value v) const { return std::to_string(v) + " us"; }
};
struct Choice {
  using Value = bool;
  const char* first;
  const char* second;
  bool parse(std::string_view text, Value& out) const {
    if (text != first && text != second) return false;
    out = text == second;
    return true;
  }
  std::string expected() const { return std::string("expected ") + first + " or " + second; }
  std::string text(Value v) const { return v ? second : first; }
};
template <class T>
struct Code32 {  // the loader parses it as an integer 0..0xFFFFFFFF
  using Value = T;
  std::string expected() const { return "expected a 32-bit code 0..0xFFFFFFFF"; }
  std::string text(Value v) const {
    char buf[16];
    std::snprintf(buf, sizeof buf, "0x%08X", unsigned(v));
    return buf;
  }
};
}  // namespace option_kind

// One line each, as they read (clang-format would split them in two).
// clang-format off
#define CANSIM_SETTING_KIND_TIME ::cansim::option_kind::Time{}
#define CANSIM_SETTING_KIND_BOOL ::cansim::option_kind::Bool{}
#define CANSIM_SETTING_KIND_CHOICE(a, b) ::cansim::option_kind::Choice{a, b}
#define CANSIM_SETTING_KIND_ENUM(T) ::cansim::option_kind::Enum<T>{}
#define CANSIM_SETTING_KIND_BYTES ::cansim::option_kind::Bytes{}
#define CANSIM_SETTING_KIND_CODE32 ::cansim::option_kind::Code32<std::uint32_t>{}
#define CANSIM_SETTING_KIND_ABORT ::cansim::option_kind::Code32<SdoAbort>{}
// clang-format on

#define CANSIM_CIA404_SETTINGS(X)                                                                                     \
  /* TPDO events (CiA 404 0x6133-0x6136, CiA 301 §7.2.2.2) */                                                        \
  X(TIME, event_check_period, event_check_period_us, 0, SETTING, "delta / limit check period (0: the sample period)") \
  X(BYTES, event_tpdo_types, event_tpdo_types, "254-255", SETTING,                                                    \
    "TPDO types whose mapped PVs get delta / limit events")                                                           \
  X(BYTES, change_event_tpdo_types, change_event_tpdo_types, "", SETTING,                                             \
    "TPDO types whose mapped PVs get an event on every change")                                                       \
  X(CHOICE("mapped", "all"), event_channels, events_all_channels, false, SETTING,                                     \
    "check delta / limits on the mapped channels or on every channel")                                                \
  X(CHOICE("edge", "level"), limit_trigger, limit_level, false, SETTING,                                              \
    "a limit raises one event per crossing (edge) or one per check while beyond it (level)")                          \
  X(ENUM(model::FilterTypeCode), filter_type_without_object, filter_type_without_object, "none", SETTING,             \
    "0x61A0 value assumed when the profile has none")                                                                 \
  X(CODE32, autozero_signature, autozero_signature, 0x6F72657A, SETTING,                                              \
    "the value a 0x6125 write must carry ('zero')")                                                                   \
  /* Vendor deviations (strict mode: CiA 404 / CiA 301) */                                                            \
  X(ENUM(model::DigitsOnUnitChange), digits_on_unit_change, digits_on_unit_change, "keep", CIA,                       \
    "0x6132 on a 0x6131 change: keep | reject | clamp | adjust")                                                      \
  X(CHOICE("offset", "correction"), autozero_target, autozero_to_correction, false, CIA,                              \
    "autozero sets the offset 0x6124 or a hidden correction")                                                         \
  X(BOOL, unit_informational, unit_informational, false, CIA, "0x6131 accepts any code and converts nothing")         \
  X(CHOICE("pv", "input"), span_compare, span_compares_input, false, CIA,                                             \
    "0x6150 judges the PV or the value before the offset against the span")                                           \
  X(ABORT, bad_unit_abort, bad_unit_abort, SdoAbort::kInvalidValue, CIA, "abort code for a unit not accepted")        \
  X(ABORT, bad_autozero_abort, bad_autozero_abort, SdoAbort::kInvalidValue, CIA,                                      \
    "abort code for a wrong autozero signature")                                                                      \
  X(ABORT, digits_abort, digits_abort, SdoAbort::kValueTooHigh, CIA, "abort code for 0x6132 above the unit's digits") \
  X(ABORT, unit_digits_abort, unit_digits_abort, SdoAbort::kParamIncompatible, CIA,                                   \
    "abort code for a unit the present 0x6132 does not fit")                                                          \
  X(ABORT, negative_abort, negative_abort, SdoAbort::kValueTooLow, CIA, "abort code for a negative delta / hysteresis")

namespace model {

struct Cia404Settings {
#define CANSIM_DECLARE_SETTING(kind, key, field, def, strict, help) \
  decltype(CANSIM_SETTING_KIND_##kind)::Value field = option_kind::initial(CANSIM_SETTING_KIND_##kind, def);
  CANSIM_CIA404_SETTINGS(CANSIM_DECLARE_SETTING)
#undef CANSIM_DECLARE_SETTING
};

}  // namespace model
}  // namespace cansim
