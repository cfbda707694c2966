#include "config/yaml_util.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace cansim::config {

void fail(const Where& w, const YAML::Node& n, const std::string& expected) {
  std::ostringstream os;
  os << w.file;
  if (n.IsDefined() && n.Mark().line >= 0) os << ":" << n.Mark().line + 1 << ":" << n.Mark().column + 1;
  else if (w.path.empty()) os << ":1:1";  // an empty document has no mark: the error is at its start
  os << ": " << (w.path.empty() ? "(top level)" : w.path) << ": " << expected;
  if (n.IsDefined() && n.IsScalar()) os << ", got '" << n.Scalar() << "'";
  throw ConfigError(os.str());
}

namespace {
template <typename Source>
YAML::Node load_yaml(Source& source, const std::string& file) {
  try {
    return YAML::Load(source);
  } catch (const YAML::ParserException& e) {
    std::ostringstream os;
    os << file << ":" << e.mark.line + 1 << ":" << e.mark.column + 1 << ": YAML syntax error: " << e.msg;
    throw ConfigError(os.str());
  }
}
}  // namespace

YAML::Node load_yaml_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open file: " + std::strerror(errno));
  return load_yaml(in, path);
}

YAML::Node load_yaml_text(const std::string& text, const std::string& file) { return load_yaml(text, file); }

bool parse_int_literal(const std::string& raw, std::int64_t& out) {
  std::string text;
  for (char c : raw)
    if (c != '_') text += c;
  if (text.empty()) return false;
  bool neg = false;
  std::size_t i = 0;
  if (text[0] == '-' || text[0] == '+') {
    neg = text[0] == '-';
    i = 1;
  }
  int base = 10;
  if (text.size() > i + 1 && text[i] == '0' && (text[i + 1] == 'x' || text[i + 1] == 'X')) {
    base = 16;
    i += 2;
  } else if (text.size() > i + 1 && text[i] == '0' && (text[i + 1] == 'b' || text[i + 1] == 'B')) {
    base = 2;
    i += 2;
  }
  if (i >= text.size()) return false;
  errno = 0;
  char* end = nullptr;
  unsigned long long v = std::strtoull(text.c_str() + i, &end, base);
  if (errno || *end || text[i] == '-') return false;
  if (neg) {
    if (v > 0x8000000000000000ULL) return false;
    out = -std::int64_t(v - 1) - 1;
  } else {
    out = std::int64_t(v);  // values above INT64_MAX wrap, callers treating them as uint64 are fine
  }
  return true;
}

std::int64_t get_int(const Where& w, const YAML::Node& n, std::int64_t lo, std::int64_t hi) {
  std::int64_t v = 0;
  if (!n.IsScalar() || !parse_int_literal(n.Scalar(), v))
    fail(w, n, "expected an integer in " + std::to_string(lo) + ".." + std::to_string(hi));
  if (v < lo || v > hi) fail(w, n, "expected an integer in " + std::to_string(lo) + ".." + std::to_string(hi));
  return v;
}

std::uint64_t get_uint(const Where& w, const YAML::Node& n) {
  std::int64_t v = 0;
  if (!n.IsScalar() || !parse_int_literal(n.Scalar(), v) || n.Scalar()[0] == '-')
    fail(w, n, "expected a non-negative integer");
  return std::uint64_t(v);
}

double get_double(const Where& w, const YAML::Node& n) {
  if (!n.IsScalar()) fail(w, n, "expected a number");
  std::int64_t i = 0;
  if (parse_int_literal(n.Scalar(), i)) return double(i);
  const std::string& s = n.Scalar();
  char* end = nullptr;
  errno = 0;
  double v = std::strtod(s.c_str(), &end);
  if (s.empty() || *end || errno || !std::isfinite(v)) fail(w, n, "expected a number");
  return v;
}

bool get_bool(const Where& w, const YAML::Node& n) {
  if (n.IsScalar()) {
    std::string s = n.Scalar();
    std::transform(s.begin(), s.end(), s.begin(), ::tolower);
    if (s == "true" || s == "yes" || s == "on") return true;
    if (s == "false" || s == "no" || s == "off") return false;
  }
  fail(w, n, "expected true or false");
}

std::string get_string(const Where& w, const YAML::Node& n) {
  if (!n.IsScalar()) fail(w, n, "expected a string");
  return n.Scalar();
}

void check_keys(const Where& w, const YAML::Node& map, std::initializer_list<const char*> known) {
  if (!map.IsMap()) fail(w, map, "expected a mapping");
  for (const auto& kv : map) {
    std::string k = kv.first.Scalar();
    bool found = std::any_of(known.begin(), known.end(), [&](const char* x) { return k == x; });
    if (!found) {
      std::string list;
      for (const char* x : known) list += (list.empty() ? "" : ", ") + std::string(x);
      fail(w.child(k), kv.first, "unknown key (expected one of: " + list + ")");
    }
  }
}

}  // namespace cansim::config
