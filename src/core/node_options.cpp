#include "core/node_options.hpp"

#include <cstdio>
#include <cstdlib>

namespace cansim {

namespace {

// The kind column of CANSIM_NODE_OPTIONS as values: CIA(v) -> CiaValue{v}.
struct SettingKind {};
template <class T>
struct CiaValue {
  T value;
};
template <class T>
CiaValue(T) -> CiaValue<T>;
#define CANSIM_KIND_SETTING SettingKind{}
#define CANSIM_KIND_CIA(v) CiaValue{v}

template <class Field>
void apply_strict(Field&, SettingKind) {}
template <class Field, class T>
void apply_strict(Field& field, CiaValue<T> cia) {
  field = Field(cia.value);
}
constexpr bool deviates(SettingKind) { return false; }
template <class T>
constexpr bool deviates(CiaValue<T>) {
  return true;
}

std::string text_of(bool v) { return v ? "true" : "false"; }
std::string text_of(const std::string& v) { return '"' + v + '"'; }
// Abort and EMCY codes read best in hex, counts and times in decimal.
std::string text_of(std::int64_t v) {
  char buf[32];
  if (v >= 0x10000) std::snprintf(buf, sizeof buf, "0x%08llX", static_cast<unsigned long long>(v));
  else if (v >= 0x100) std::snprintf(buf, sizeof buf, "0x%llX", static_cast<unsigned long long>(v));
  else std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(v));
  return buf;
}

}  // namespace

void make_strict(NodeOptions& o) {
#define CANSIM_STRICT_OPTION(type, name, def, kind, help) apply_strict(o.name, CANSIM_KIND_##kind);
  CANSIM_NODE_OPTIONS(CANSIM_STRICT_OPTION)
#undef CANSIM_STRICT_OPTION
}

const std::vector<OptionInfo>& option_infos() {
  static const std::vector<OptionInfo> infos = {
#define CANSIM_OPTION_INFO(type, name, def, kind, help) {#name, deviates(CANSIM_KIND_##kind)},
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
#define CANSIM_OPTION_TEXT(type, name_, def, kind, help) \
  if (name == #name_) return text_of(o.name_);
  CANSIM_NODE_OPTIONS(CANSIM_OPTION_TEXT)
#undef CANSIM_OPTION_TEXT
  return {};
}

std::vector<std::string> differing_options(const NodeOptions& a, const NodeOptions& b) {
  std::vector<std::string> names;
#define CANSIM_OPTION_DIFFERS(type, name, def, kind, help) \
  if (a.name != b.name) names.push_back(#name);
  CANSIM_NODE_OPTIONS(CANSIM_OPTION_DIFFERS)
#undef CANSIM_OPTION_DIFFERS
  return names;
}

bool ByteSet::parse(const std::string& text, ByteSet& out) {
  out = ByteSet{};
  const char* p = text.c_str();
  while (*p) {
    while (*p == ' ' || *p == ',') ++p;
    if (!*p) break;
    char* end = nullptr;
    long lo = std::strtol(p, &end, 0);
    if (end == p || lo < 0 || lo > 255) return false;
    long hi = lo;
    p = end;
    while (*p == ' ') ++p;
    if (*p == '-') {
      ++p;
      hi = std::strtol(p, &end, 0);
      if (end == p || hi < lo || hi > 255) return false;
      p = end;
    }
    for (long v = lo; v <= hi; ++v) out.add(std::uint8_t(v));
    while (*p == ' ') ++p;
    if (*p && *p != ',') return false;
  }
  return true;
}

}  // namespace cansim
