#include "core/node_options.hpp"

#include <charconv>
#include <cstdio>

namespace cansim {

namespace {

// The strict column of CANSIM_NODE_OPTIONS as values: CIA(v) -> CiaValue{v}.
struct SettingKind {};
template <class T>
struct CiaValue {
  T value;
};
template <class T>
CiaValue(T) -> CiaValue<T>;
#define CANSIM_STRICT_SETTING \
  SettingKind {}
#define CANSIM_STRICT_CIA(v) \
  CiaValue { v }

template <class Kind, class Field>
void apply_strict(Kind, Field&, SettingKind) {}
template <class Kind, class Field, class T>
void apply_strict(Kind kind, Field& field, CiaValue<T> cia) {
  if constexpr (std::is_convertible_v<T, const char*>) {
    if (!kind.parse(cia.value, field)) std::abort();  // a CiA value the kind refuses: a bug
  } else {
    field = Field(cia.value);
  }
}
constexpr bool deviates(SettingKind) { return false; }
template <class T>
constexpr bool deviates(CiaValue<T>) {
  return true;
}

// Text as a profile writes it, quoted where YAML needs quotes for a string.
template <class Kind>
std::string quoted_text(const Kind& kind, const typename Kind::Value& v) {
  if constexpr (std::is_same_v<Kind, option_kind::Bool> || std::is_same_v<Kind, option_kind::Int>) return kind.text(v);
  else return '"' + kind.text(v) + '"';
}

const char* skip_separators(const char* p, const char* end) {
  while (p < end && (*p == ' ' || *p == ',' || *p == '\t')) ++p;
  return p;
}

// An unsigned number (decimal or 0x hex) at p; false when there is none or it exceeds max.
bool read_number(const char*& p, const char* end, std::uint64_t max, std::uint64_t& out) {
  int base = 10;
  if (end - p > 2 && p[0] == '0' && (p[1] == 'x' || p[1] == 'X')) {
    base = 16;
    p += 2;
  }
  const auto [next, ec] = std::from_chars(p, end, out, base);
  if (ec != std::errc() || next == p || out > max) return false;
  p = next;
  return true;
}

// "lo" or "lo-hi" at p, both within 0..max.
bool read_range(const char*& p, const char* end, std::uint64_t max, std::uint64_t& lo, std::uint64_t& hi) {
  if (!read_number(p, end, max, lo)) return false;
  hi = lo;
  while (p < end && *p == ' ') ++p;
  if (p < end && *p == '-') {
    ++p;
    while (p < end && *p == ' ') ++p;
    if (!read_number(p, end, max, hi) || hi < lo) return false;
  }
  while (p < end && *p == ' ') ++p;
  return p == end || *p == ',';
}

void append_range(std::string& s, std::uint64_t lo, std::uint64_t hi, bool hex) {
  char buf[48];
  if (hex && lo == hi) std::snprintf(buf, sizeof buf, "0x%04llX", static_cast<unsigned long long>(lo));
  else if (hex)
    std::snprintf(buf, sizeof buf, "0x%04llX-0x%04llX", static_cast<unsigned long long>(lo),
                  static_cast<unsigned long long>(hi));
  else if (lo == hi) std::snprintf(buf, sizeof buf, "%llu", static_cast<unsigned long long>(lo));
  else
    std::snprintf(buf, sizeof buf, "%llu-%llu", static_cast<unsigned long long>(lo),
                  static_cast<unsigned long long>(hi));
  if (!s.empty()) s += ',';
  s += buf;
}

}  // namespace

// ---------------------------------------------------------------- value types

bool ByteSet::parse(std::string_view text, ByteSet& out) {
  out = ByteSet{};
  const char* end = text.data() + text.size();
  for (const char* p = skip_separators(text.data(), end); p < end; p = skip_separators(p, end)) {
    std::uint64_t lo = 0, hi = 0;
    if (!read_range(p, end, 255, lo, hi)) return false;
    for (std::uint64_t v = lo; v <= hi; ++v) out.add(std::uint8_t(v));
  }
  return true;
}

std::string ByteSet::text() const {
  std::string s;
  for (int v = 0; v < 256; ++v) {
    if (!has(std::uint8_t(v))) continue;
    int last = v;
    while (last < 255 && has(std::uint8_t(last + 1))) ++last;
    append_range(s, std::uint64_t(v), std::uint64_t(last), false);
    v = last;
  }
  return s;
}

bool RangeList::contains(std::uint64_t v) const {
  if (count == 0) return true;
  for (int i = 0; i < count; ++i)
    if (v >= lo[i] && v <= hi[i]) return true;
  return false;
}

bool RangeList::parse(std::string_view text, std::uint32_t max, RangeList& out) {
  out = RangeList{};
  const char* end = text.data() + text.size();
  for (const char* p = skip_separators(text.data(), end); p < end; p = skip_separators(p, end)) {
    std::uint64_t a = 0, b = 0;
    if (out.count == kMax || !read_range(p, end, max, a, b)) return false;
    out.lo[out.count] = std::uint32_t(a);
    out.hi[out.count++] = std::uint32_t(b);
  }
  return true;
}

std::string RangeList::text(std::uint32_t max) const {
  std::string s;
  for (int i = 0; i < count; ++i) append_range(s, lo[i], hi[i], max > 0xFF);
  return s;
}

std::uint32_t AbortMap::apply(std::uint32_t code) const {
  for (int i = 0; i < count; ++i)
    if (from[i] == code) return to[i];
  return code;
}

bool AbortMap::parse(std::string_view text, AbortMap& out) {
  out = AbortMap{};
  const char* end = text.data() + text.size();
  for (const char* p = skip_separators(text.data(), end); p < end; p = skip_separators(p, end)) {
    std::uint64_t a = 0, b = 0;
    if (out.count == kMax || !read_number(p, end, 0xFFFFFFFF, a) || p == end || *p++ != '=' ||
        !read_number(p, end, 0xFFFFFFFF, b) || (p < end && *p != ',' && *p != ' '))
      return false;
    out.from[out.count] = std::uint32_t(a);
    out.to[out.count++] = std::uint32_t(b);
  }
  return true;
}

std::string AbortMap::text() const {
  std::string s;
  char buf[32];
  for (int i = 0; i < count; ++i) {
    std::snprintf(buf, sizeof buf, "%s0x%08X=0x%08X", i ? "," : "", unsigned(from[i]), unsigned(to[i]));
    s += buf;
  }
  return s;
}

// ---------------------------------------------------------------- kinds

namespace option_kind {

bool Bool::parse(std::string_view text, Value& out) const {
  if (text == "true") out = true;
  else if (text == "false") out = false;
  else return false;
  return true;
}

bool Int::parse(std::string_view text, Value& out) const {
  const bool negative = !text.empty() && text[0] == '-';
  const char* p = text.data() + (negative ? 1 : 0);
  const char* end = text.data() + text.size();
  std::uint64_t v = 0;
  if (!read_number(p, end, std::uint64_t(INT64_MAX), v) || p != end) return false;
  const std::int64_t n = negative ? -std::int64_t(v) : std::int64_t(v);
  if (n < lo || n > hi) return false;
  out = n;
  return true;
}

namespace {
// A range bound: all-ones masks from 0xFFFF up in hex, others in decimal.
std::string bound_text(std::int64_t v) {
  char buf[32];
  const bool mask = v >= 0xFFFF && (v & (v + 1)) == 0;
  std::snprintf(buf, sizeof buf, mask ? "0x%llX" : "%lld", static_cast<long long>(v));
  return buf;
}
}  // namespace

std::string Int::expected() const { return "expected an integer in " + bound_text(lo) + ".." + bound_text(hi); }

// Abort and EMCY codes read best in hex, counts and times in decimal.
std::string Int::text(Value v) const {
  char buf[32];
  if (v >= 0x10000) std::snprintf(buf, sizeof buf, "0x%08llX", static_cast<unsigned long long>(v));
  else if (v >= 0x100) std::snprintf(buf, sizeof buf, "0x%llX", static_cast<unsigned long long>(v));
  else std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(v));
  return buf;
}

std::string Ranges::expected() const {
  return "expected ranges of values 0.." + bound_text(max) + (max > 0xFF ? " like '0x4020-0x4022'" : " like '0,2,8'") +
         " (empty: every value)";
}

}  // namespace option_kind

// ---------------------------------------------------------------- the option table

void make_strict(NodeOptions& o) {
#define CANSIM_STRICT_OPTION(kind, name, def, strict, help) \
  apply_strict(CANSIM_OPTION_KIND_##kind, o.name, CANSIM_STRICT_##strict);
  CANSIM_NODE_OPTIONS(CANSIM_STRICT_OPTION)
#undef CANSIM_STRICT_OPTION
}

const std::vector<OptionInfo>& option_infos() {
  static const std::vector<OptionInfo> infos = {
#define CANSIM_OPTION_INFO(kind, name, def, strict, help) {#name, deviates(CANSIM_STRICT_##strict)},
      CANSIM_NODE_OPTIONS(CANSIM_OPTION_INFO)
#undef CANSIM_OPTION_INFO
  };
  return infos;
}

const OptionInfo* find_option(std::string_view name) {
  for (const OptionInfo& i : option_infos())
    if (name == i.name) return &i;
  return nullptr;
}

std::string option_text(const NodeOptions& o, std::string_view name) {
#define CANSIM_OPTION_TEXT(kind, name_, def, strict, help) \
  if (name == #name_) return quoted_text(CANSIM_OPTION_KIND_##kind, o.name_);
  CANSIM_NODE_OPTIONS(CANSIM_OPTION_TEXT)
#undef CANSIM_OPTION_TEXT
  return {};
}

std::vector<std::string> differing_options(const NodeOptions& a, const NodeOptions& b) {
  std::vector<std::string> names;
#define CANSIM_OPTION_DIFFERS(kind, name, def, strict, help) \
  if (!(a.name == b.name)) names.push_back(#name);
  CANSIM_NODE_OPTIONS(CANSIM_OPTION_DIFFERS)
#undef CANSIM_OPTION_DIFFERS
  return names;
}

}  // namespace cansim
