// Object values, object addresses and durations as cansimctl reads them from
// its command line and prints them.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace cansim::ctl {

using Bytes = std::vector<std::uint8_t>;

// An object value as Node1.Read returns it and Node1.Write takes it: the D-Bus
// types b y n q i u x t d s ay (docs/control-api.md, Read).
using Value = std::variant<bool, std::uint8_t, std::int16_t, std::uint16_t, std::int32_t, std::uint32_t, std::int64_t,
                           std::uint64_t, double, std::string, Bytes>;

// The D-Bus signature of the value's type: "b", "y", ..., "s", "ay".
const char* signature(const Value& v);

// ---------------------------------------------------------------- parsing

// An unsigned integer: decimal or 0x hex, nothing else around it.
std::optional<std::uint64_t> parse_unsigned(std::string_view text);

// A decimal number, optionally signed: "5", "-1.5", "2e3" (no hex, no units).
std::optional<double> parse_real(std::string_view text);

struct ObjectAddress {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  bool operator==(const ObjectAddress&) const = default;
};

// INDEX[:SUB]: each 0x hex, hex with a CiA-style 'h' suffix (1017h) or
// decimal; SUB defaults to 0.
std::optional<ObjectAddress> parse_object_address(std::string_view text);

// A duration or simulated time: a number (≥ 0) and an optional unit s, ms, us,
// µs, min or h (seconds when omitted), with or without a space between them.
std::optional<double> parse_duration_seconds(std::string_view text);

// The same text as the daemon's profile parser reads it best: "500ms" ->
// "500 ms", "1.5" -> "1.5 s". nullopt when it is no duration.
std::optional<std::string> normalise_duration(std::string_view text);

// Hex bytes, optionally separated by spaces, ':' or '-' and prefixed 0x:
// "01 02 ff", "0102ff", "01:02:ff".
std::optional<Bytes> parse_bytes(std::string_view text);

// The value Write sends for VALUE. type empty: typed by its look (integers
// as x, or t above INT64_MAX; 0x hex as t; decimals as d; text, or text in
// double quotes, as s). Otherwise one of write_type_names() forces the type.
// nullopt when the text does not fit the type.
std::optional<Value> typed_value(std::string_view text, std::string_view type = {});

// The names --type accepts, space-separated, for the usage text.
const char* write_type_names();
bool is_write_type(std::string_view type);

// ---------------------------------------------------------------- printing

// The shortest text that reads back as d; a value that is exactly a float
// (a REAL32 object) prints as that float: 0.1f is "0.1", not "0.100000001".
// No exponent between 1e-6 and 1e15 ("9990440", not "9.99044e+06").
std::string format_number(double d);

// A measured quantity for people, readable at every magnitude: a REAL32
// value as its float's shortest text, another double to six significant
// digits, never with an exponent, the whole part above 9999 in groups of
// three ("9 990 440", "2.4996", "0.00012"); "-" for NaN.
std::string format_measure(double d);

// Simulated time in µs as seconds: "12.345678".
std::string format_seconds(std::int64_t us);

// "01 02 ff".
std::string format_bytes(const Bytes& b);

enum class IntegerStyle { kDecimal, kHex, kBoth };

// Human text: integers per style ("1000", "0x3e8", "1000 (0x3e8)"; negative
// integers in hex as their two's complement at the type's width), booleans
// true/false, strings as they are, bytes in hex.
std::string format_value(const Value& v, IntegerStyle style = IntegerStyle::kBoth);

// Natural order: digit runs compare as numbers ("pt/2" before "pt/10").
bool natural_less(std::string_view a, std::string_view b);

}  // namespace cansim::ctl
