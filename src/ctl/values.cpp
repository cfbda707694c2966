#include "ctl/values.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <type_traits>

namespace cansim::ctl {

namespace {

template <typename T>
std::optional<T> parse_whole(std::string_view text, int base) {
  T out{};
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, out, base);
  if (text.empty() || ec != std::errc() || ptr != end) return std::nullopt;
  return out;
}

bool has_hex_prefix(std::string_view text) {
  return text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X');
}

bool is_digit(char c) { return c >= '0' && c <= '9'; }

std::size_t count_digits(std::string_view s, std::size_t from) {
  std::size_t i = from;
  while (i < s.size() && is_digit(s[i])) ++i;
  return i - from;
}

// Length of the unsigned decimal literal ("12", "1.5", ".5", "2e-3") at the
// start of s, 0 when there is none; integral tells whether it has neither a
// fraction nor an exponent.
std::size_t decimal_prefix(std::string_view s, bool& integral) {
  std::size_t n = count_digits(s, 0);
  std::size_t fraction = 0;
  integral = true;
  if (n < s.size() && s[n] == '.') {
    fraction = count_digits(s, n + 1);
    if (n == 0 && fraction == 0) return 0;
    n += 1 + fraction;
    integral = false;
  }
  if (n == 0) return 0;
  if (n < s.size() && (s[n] == 'e' || s[n] == 'E')) {
    std::size_t sign = n + 1 < s.size() && (s[n + 1] == '+' || s[n + 1] == '-') ? 1 : 0;
    if (std::size_t exp = count_digits(s, n + 1 + sign)) {
      n += 1 + sign + exp;
      integral = false;
    }
  }
  return n;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
  while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
  return s;
}

std::optional<double> parse_double(std::string_view text) {
  double out = 0;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, out);
  if (text.empty() || ec != std::errc() || ptr != end) return std::nullopt;
  return out;
}

// ---------------------------------------------------------------- durations

struct Duration {
  std::string_view number;
  std::string_view unit;  // "" when omitted
  double seconds = 0;
};

struct TimeUnit {
  std::string_view name;
  double seconds;
};
constexpr TimeUnit kTimeUnits[] = {{"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}, {"µs", 1e-6}, {"min", 60.0}, {"h", 3600.0}};

std::optional<Duration> split_duration(std::string_view text) {
  text = trim(text);
  bool integral = false;
  std::size_t n = decimal_prefix(text, integral);
  if (n == 0) return std::nullopt;
  Duration d{text.substr(0, n), trim(text.substr(n)), 0.0};
  auto number = parse_double(d.number);
  if (!number) return std::nullopt;
  double scale = d.unit.empty() ? 1.0 : 0.0;
  for (const TimeUnit& u : kTimeUnits) {
    if (u.name == d.unit) scale = u.seconds;
  }
  if (scale == 0.0) return std::nullopt;
  d.seconds = *number * scale;
  return d;
}

// ---------------------------------------------------------------- write types

struct WriteType {
  std::string_view name;
  char kind;  // b: boolean, u: unsigned, i: signed, d: double, s: string, a: bytes
  int bits;
};
constexpr WriteType kWriteTypes[] = {{"bool", 'b', 1}, {"u8", 'u', 8},   {"u16", 'u', 16}, {"u32", 'u', 32},
                                     {"u64", 'u', 64}, {"i8", 'i', 8},   {"i16", 'i', 16}, {"i32", 'i', 32},
                                     {"i64", 'i', 64}, {"f32", 'd', 32}, {"f64", 'd', 64}, {"str", 's', 0},
                                     {"bytes", 'a', 0}};

const WriteType* find_write_type(std::string_view name) {
  for (const WriteType& t : kWriteTypes) {
    if (t.name == name) return &t;
  }
  return nullptr;
}

std::optional<std::int64_t> parse_signed(std::string_view text) {
  bool negative = !text.empty() && text[0] == '-';
  if (negative) text.remove_prefix(1);
  auto magnitude = parse_unsigned(text);
  constexpr auto kMinMagnitude = std::uint64_t(std::numeric_limits<std::int64_t>::max()) + 1;
  if (!magnitude || *magnitude > (negative ? kMinMagnitude : kMinMagnitude - 1)) return std::nullopt;
  return negative ? std::int64_t(-*magnitude) : std::int64_t(*magnitude);
}

// D-Bus has no signed byte: i8 travels as n (int16), range-checked as 8 bits.
std::optional<Value> signed_value(std::string_view text, int bits) {
  auto v = parse_signed(text);
  if (!v) return std::nullopt;
  std::int64_t limit = bits == 64 ? 0 : std::int64_t(1) << (bits - 1);
  if (bits < 64 && (*v < -limit || *v >= limit)) return std::nullopt;
  if (bits <= 16) return Value(std::int16_t(*v));
  if (bits == 32) return Value(std::int32_t(*v));
  return Value(*v);
}

std::optional<Value> unsigned_value(std::string_view text, int bits) {
  auto v = parse_unsigned(text);
  if (!v || (bits < 64 && *v >> bits)) return std::nullopt;
  if (bits == 8) return Value(std::uint8_t(*v));
  if (bits == 16) return Value(std::uint16_t(*v));
  if (bits == 32) return Value(std::uint32_t(*v));
  return Value(*v);
}

std::optional<Value> boolean_value(std::string_view text) {
  if (text == "true" || text == "1") return Value(true);
  if (text == "false" || text == "0") return Value(false);
  return std::nullopt;
}

std::string_view without_sign(std::string_view text) {
  return text.substr(!text.empty() && (text[0] == '-' || text[0] == '+') ? 1 : 0);
}

std::optional<Value> number_value(std::string_view text) {
  std::string_view unsigned_part = without_sign(text);
  bool integral = false;
  if (decimal_prefix(unsigned_part, integral) != unsigned_part.size() || unsigned_part.empty()) return std::nullopt;
  if (!text.empty() && text[0] == '+') text.remove_prefix(1);
  if (!integral) {
    auto d = parse_double(text);
    return d ? std::optional<Value>(*d) : std::nullopt;
  }
  if (auto v = parse_whole<std::int64_t>(text, 10)) return Value(*v);
  if (auto v = parse_whole<std::uint64_t>(text, 10)) return Value(*v);
  return std::nullopt;  // beyond 64 bits
}

std::optional<Value> value_by_look(std::string_view text) {
  if (text.size() >= 2 && text.front() == '"' && text.back() == '"')
    return Value(std::string(text.substr(1, text.size() - 2)));
  if (has_hex_prefix(text)) {
    auto v = parse_unsigned(text);
    return v ? std::optional<Value>(*v) : std::nullopt;
  }
  std::string_view unsigned_part = without_sign(text);
  if (!unsigned_part.empty() && (is_digit(unsigned_part[0]) || unsigned_part[0] == '.')) return number_value(text);
  return Value(std::string(text));
}

int hex_digit(char c) {
  if (is_digit(c)) return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

const char* signature(const Value& v) {
  static constexpr const char* kSignatures[] = {"b", "y", "n", "q", "i", "u", "x", "t", "d", "s", "ay"};
  static_assert(std::size(kSignatures) == std::variant_size_v<Value>);
  return kSignatures[v.index()];
}

std::optional<std::uint64_t> parse_unsigned(std::string_view text) {
  if (has_hex_prefix(text)) return parse_whole<std::uint64_t>(text.substr(2), 16);
  return parse_whole<std::uint64_t>(text, 10);
}

std::optional<double> parse_real(std::string_view text) {
  auto v = number_value(text);
  if (!v) return std::nullopt;
  return std::visit(
      [](auto n) -> std::optional<double> {
        if constexpr (std::is_arithmetic_v<decltype(n)>) return double(n);
        return std::nullopt;
      },
      *v);
}

std::optional<ObjectAddress> parse_object_address(std::string_view text) {
  auto number = [](std::string_view t) -> std::optional<std::uint64_t> {
    bool h_suffix = t.size() > 1 && (t.back() == 'h' || t.back() == 'H');
    return h_suffix ? parse_whole<std::uint64_t>(t.substr(0, t.size() - 1), 16) : parse_unsigned(t);
  };
  std::size_t colon = text.find(':');
  auto index = number(text.substr(0, colon));
  auto sub = colon == std::string_view::npos ? std::optional<std::uint64_t>(0) : number(text.substr(colon + 1));
  if (!index || !sub || *index > 0xFFFF || *sub > 0xFF) return std::nullopt;
  return ObjectAddress{std::uint16_t(*index), std::uint8_t(*sub)};
}

std::optional<double> parse_duration_seconds(std::string_view text) {
  auto d = split_duration(text);
  return d ? std::optional<double>(d->seconds) : std::nullopt;
}

std::optional<std::string> normalise_duration(std::string_view text) {
  auto d = split_duration(text);
  if (!d) return std::nullopt;
  return std::string(d->number) + " " + std::string(d->unit.empty() ? "s" : d->unit);
}

std::optional<Bytes> parse_bytes(std::string_view text) {
  if (has_hex_prefix(text)) text.remove_prefix(2);
  Bytes out;
  int high = -1;
  for (char c : text) {
    if (c == ' ' || c == ':' || c == '-') {
      if (high >= 0) return std::nullopt;  // a separator splits a byte
      continue;
    }
    int digit = hex_digit(c);
    if (digit < 0) return std::nullopt;
    if (high < 0) {
      high = digit;
    } else {
      out.push_back(std::uint8_t(high << 4 | digit));
      high = -1;
    }
  }
  if (high >= 0) return std::nullopt;
  return out;
}

std::optional<Value> typed_value(std::string_view text, std::string_view type) {
  if (type.empty()) return value_by_look(text);
  const WriteType* t = find_write_type(type);
  if (!t) return std::nullopt;
  switch (t->kind) {
    case 'b': return boolean_value(text);
    case 'u': return unsigned_value(text, t->bits);
    case 'i': return signed_value(text, t->bits);
    case 'd': {
      auto d = parse_real(text);
      return d ? std::optional<Value>(*d) : std::nullopt;
    }
    case 's': return Value(std::string(text));
    case 'a': {
      auto b = parse_bytes(text);
      return b ? std::optional<Value>(*b) : std::nullopt;
    }
  }
  return std::nullopt;
}

const char* write_type_names() { return "bool u8 u16 u32 u64 i8 i16 i32 i64 f32 f64 str bytes"; }

bool is_write_type(std::string_view type) { return find_write_type(type) != nullptr; }

std::string format_number(double d) {
  char buf[128];
  const auto f = static_cast<float>(d);
  const bool is_float = std::isfinite(d) && static_cast<double>(f) == d;
  const double magnitude = std::fabs(d);
  const bool fixed = magnitude == 0 || (magnitude >= 1e-6 && magnitude < 1e15);
  const auto format = fixed ? std::chars_format::fixed : std::chars_format::general;
  auto r = is_float ? std::to_chars(buf, buf + sizeof buf, f, format) : std::to_chars(buf, buf + sizeof buf, d, format);
  return std::string(buf, r.ptr);
}

namespace {

// "9990440.5" -> "9 990 440.5"; a whole part of four digits stays as it is.
std::string grouped(std::string text) {
  const std::size_t start = !text.empty() && text[0] == '-' ? 1 : 0;
  const std::size_t point = std::min(text.find('.'), text.size());
  if (point - start <= 4 || text.find_first_not_of("-0123456789.") != std::string::npos) return text;
  for (std::size_t i = point; i > start + 3;) {
    i -= 3;
    text.insert(i, 1, ' ');
  }
  return text;
}

}  // namespace

std::string format_measure(double d) {
  if (std::isnan(d)) return "-";
  const auto f = static_cast<float>(d);
  if (!std::isfinite(d) || static_cast<double>(f) == d) return grouped(format_number(d));
  const double magnitude = std::fabs(d);
  if (magnitude < 1e-6 || magnitude >= 1e15) return format_number(d);
  const int exponent = int(std::floor(std::log10(magnitude)));
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", std::clamp(5 - exponent, 0, 12), d);
  std::string text = buf;
  if (text.find('.') != std::string::npos) {
    text.erase(text.find_last_not_of('0') + 1);
    if (text.back() == '.') text.pop_back();
  }
  return grouped(text);
}

std::string format_seconds(std::int64_t us) {
  std::uint64_t magnitude = us < 0 ? std::uint64_t(0) - std::uint64_t(us) : std::uint64_t(us);
  std::string fraction = std::to_string(magnitude % 1000000);
  fraction.insert(0, 6 - fraction.size(), '0');
  return (us < 0 ? "-" : "") + std::to_string(magnitude / 1000000) + "." + fraction;
}

std::string format_bytes(const Bytes& b) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (std::uint8_t byte : b) {
    if (!out.empty()) out += ' ';
    out += kHex[byte >> 4];
    out += kHex[byte & 0xF];
  }
  return out;
}

std::string format_value(const Value& v, IntegerStyle style) {
  return std::visit(
      [style](const auto& x) -> std::string {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, bool>) {
          return x ? "true" : "false";
        } else if constexpr (std::is_integral_v<T>) {
          char hex[24] = "0x";
          auto end = std::to_chars(hex + 2, hex + sizeof hex, std::make_unsigned_t<T>(x), 16).ptr;
          std::string h(hex, end);
          if (style == IntegerStyle::kHex) return h;
          std::string decimal = std::to_string(x);
          return style == IntegerStyle::kBoth ? decimal + " (" + h + ")" : decimal;
        } else if constexpr (std::is_same_v<T, double>) {
          return format_number(x);
        } else if constexpr (std::is_same_v<T, std::string>) {
          return x;
        } else {
          return format_bytes(x);
        }
      },
      v);
}

bool natural_less(std::string_view a, std::string_view b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (is_digit(a[i]) && is_digit(b[j])) {
      std::size_t i0 = i, j0 = j;
      while (i0 < a.size() && a[i0] == '0') ++i0;  // leading zeros do not count
      while (j0 < b.size() && b[j0] == '0') ++j0;
      std::size_t i1 = i0 + count_digits(a, i0), j1 = j0 + count_digits(b, j0);
      if (i1 - i0 != j1 - j0) return i1 - i0 < j1 - j0;
      if (int c = a.substr(i0, i1 - i0).compare(b.substr(j0, j1 - j0)); c != 0) return c < 0;
      i = i1, j = j1;
      continue;
    }
    if (a[i] != b[j]) return a[i] < b[j];
    ++i, ++j;
  }
  return a.size() - i < b.size() - j;
}

}  // namespace cansim::ctl
