#include "config/yaml_util.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <vector>

#include "config/limits.hpp"

namespace cansim::config {

namespace {
std::string located(const Where& w, const YAML::Node& n, const std::string& expected) {
  std::ostringstream os;
  os << w.file;
  if (n.IsDefined() && n.Mark().line >= 0) os << ":" << n.Mark().line + 1 << ":" << n.Mark().column + 1;
  else if (w.path.empty()) os << ":1:1";  // an empty document has no mark: the error is at its start
  os << ": " << (w.path.empty() ? "(top level)" : w.path) << ": " << expected;
  if (n.IsDefined() && n.IsScalar()) os << ", got '" << n.Scalar() << "'";
  return os.str();
}
}  // namespace

void fail(const Where& w, const YAML::Node& n, const std::string& expected) {
  throw ConfigError(located(w, n, expected));
}

void fail_too_large(const Where& w, const YAML::Node& n, const std::string& bound) {
  throw TooLarge(located(w, n, bound));
}

namespace {
// "source:line:column" of offset `at` in `text`.
std::string place(std::string_view text, const std::string& source, std::size_t at) {
  const std::string_view before = text.substr(0, at);
  const std::size_t line_start = before.rfind('\n');
  const std::size_t column = line_start == std::string_view::npos ? at : at - line_start - 1;
  return source + ":" + std::to_string(std::count(before.begin(), before.end(), '\n') + 1) + ":" +
         std::to_string(column + 1);
}

YamlScan check_yaml_depth(std::string_view text, const std::string& source) {
  const YamlScan scan = scan_yaml(text, limits::kYamlDepth);
  if (scan.depth > limits::kYamlDepth)
    throw TooLarge(place(text, source, scan.end) + ": (top level): YAML nested more than " +
                   std::to_string(limits::kYamlDepth) + " levels deep");
  return scan;
}

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
  return load_yaml_text(read_regular_file(path, limits::kProfileFileBytes), path);
}

YAML::Node load_yaml_text(const std::string& text, const std::string& file) {
  check_yaml_depth(text, file);
  return load_yaml(text, file);
}

namespace {

bool blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

// Index just past the quoted scalar opening at `i` ('...' with '' inside, or "..." with \ escapes).
std::size_t skip_quoted(std::string_view t, std::size_t i) {
  const char q = t[i++];
  while (i < t.size()) {
    if (q == '"' && t[i] == '\\') {
      i += 2;
    } else if (t[i] == q) {
      if (q == '\'' && i + 1 < t.size() && t[i + 1] == '\'') i += 2;
      else return i + 1;
    } else {
      ++i;
    }
  }
  return i;
}

}  // namespace

// One pass, no allocation beyond the stack of open block levels (at most
// stop_above + 1 deep). In block context a level opens at each column where a
// node starts to the right of the enclosing one; compact entries ("- - x")
// and a mapping after "- " open theirs on the same line.
int yaml_depth(std::string_view t, int stop_above, std::size_t* alias_count) {
  const YamlScan scan = scan_yaml(t, stop_above);
  if (alias_count) *alias_count = scan.aliases;
  return scan.depth;
}

YamlScan scan_yaml(std::string_view t, int stop_above) {
  YamlScan out;
  std::vector<std::size_t> levels;  // block context: the columns of the open levels
  int flow = 0, deepest = 0;
  int block_parent = -1;  // inside a block scalar: lines indented deeper than this are text
  std::size_t i = 0, line = 0;
  bool line_start = true, token_start = true;
  const auto deeper = [&](int d) {
    if (d > stop_above && deepest <= stop_above) out.end = i;  // the node that goes too deep
    deepest = std::max(deepest, d);
  };
  while (i < t.size() && deepest <= stop_above) {
    if (line_start) {
      line_start = false;
      line = i;
      std::size_t col = 0;
      while (i + col < t.size() && t[i + col] == ' ') ++col;
      const std::size_t first = i + col;
      std::size_t eol = t.find('\n', first);
      if (eol == std::string_view::npos) eol = t.size();
      const bool empty = first >= t.size() || t[first] == '\n' || t[first] == '\r' || t[first] == '#';
      if (block_parent >= 0 && (empty || int(col) > block_parent)) {
        i = eol;
        continue;
      }
      block_parent = -1;
      if (empty) {
        i = eol;
        continue;
      }
      if (flow == 0)
        while (!levels.empty() && levels.back() > col) levels.pop_back();
      token_start = true;
      i = first;
      continue;
    }
    const char c = t[i];
    const bool indicator_end = i + 1 >= t.size() || blank(t[i + 1]);
    if (c == '\n') {
      line_start = true;
      ++i;
    } else if (blank(c)) {
      ++i;
    } else if (c == '#' && (i == 0 || blank(t[i - 1]))) {
      while (i < t.size() && t[i] != '\n') ++i;
    } else {
      if (flow == 0 && token_start) {  // a node (or an entry's indicator) starts in this column
        const std::size_t col = i - line;
        if (levels.empty() || levels.back() < col) levels.push_back(col);
        deeper(int(levels.size()));
      }
      if (token_start && (c == '"' || c == '\'')) {
        i = skip_quoted(t, i);
        token_start = false;
      } else if ((c == '[' || c == '{') && (flow > 0 || token_start)) {  // in a plain scalar, text
        ++flow;
        deeper(int(levels.size()) + flow);
        token_start = true;
        ++i;
      } else if ((c == ']' || c == '}') && flow > 0) {
        --flow;
        token_start = false;
        ++i;
      } else if ((c == ',' && flow > 0) || ((c == '-' || c == '?' || c == ':') && indicator_end)) {
        token_start = true;
        ++i;
      } else if (flow == 0 && token_start && (c == '|' || c == '>')) {
        block_parent = int(levels.size() > 1 ? levels[levels.size() - 2] : 0);
        while (i < t.size() && t[i] != '\n') ++i;
      } else if (token_start && (c == '&' || c == '!' || c == '*')) {  // anchor, tag (the node follows), alias
        if (c == '*') {
          ++out.aliases;
          out.last_alias = i;
          token_start = false;
        }
        while (i < t.size() && !blank(t[i]) && !(flow > 0 && std::strchr(",[]{}", t[i]))) ++i;
      } else {
        token_start = false;
        ++i;
      }
    }
  }
  out.depth = deepest;
  if (deepest <= stop_above) out.end = t.size();
  return out;
}

void check_yaml_size(std::string_view text, const std::string& source, std::size_t max_bytes) {
  if (text.size() > max_bytes)
    throw TooLarge(source + ": " + std::to_string(text.size()) + " bytes of YAML; expected at most " +
                   std::to_string(max_bytes));
  const YamlScan scan = check_yaml_depth(text, source);
  // An alias stands for its whole anchored node: each one more is parsed again.
  if (scan.aliases > limits::kYamlAliases)
    throw TooLarge(place(text, source, scan.last_alias) + ": (top level): " + std::to_string(scan.aliases) +
                   " YAML aliases (*name); expected at most " + std::to_string(limits::kYamlAliases));
}

bool inside_any(const std::string& file, const std::vector<std::string>& dirs) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path real = fs::canonical(file, ec);
  if (ec) return false;
  for (const auto& d : dirs) {
    const fs::path root = fs::canonical(d, ec);
    if (ec) continue;
    const fs::path rel = real.lexically_relative(root);
    if (!rel.empty() && *rel.begin() != ".." && rel != ".") return true;
  }
  return false;
}

namespace {
thread_local const ConfinedFiles* confined_files = nullptr;
}

ConfinedFiles::ConfinedFiles(std::vector<std::string> folders) : folders_(std::move(folders)), outer_(confined_files) {
  confined_files = this;
}
ConfinedFiles::~ConfinedFiles() { confined_files = outer_; }
const std::vector<std::string>* ConfinedFiles::current() {
  return confined_files ? &confined_files->folders_ : nullptr;
}

thread_local FilesRead* files_read = nullptr;

FilesRead::FilesRead() : outer_(files_read) { files_read = this; }
FilesRead::~FilesRead() { files_read = outer_; }
void FilesRead::note(const std::string& path, const std::string& text) {
  if (files_read) files_read->files_.emplace_back(path, text);
}

std::string read_regular_file(const std::string& path, std::size_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) throw ConfigError(path + ": cannot open file: " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw ConfigError(path + ": cannot open file: " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) throw ConfigError(path + ": not a regular file");
  if (std::size_t(st.st_size) > max_bytes)
    throw TooLarge(path + ": " + std::to_string(st.st_size) + " bytes; expected at most " + std::to_string(max_bytes));
  std::string out(std::size_t(st.st_size), '\0');
  std::size_t got = 0;
  while (got < out.size()) {  // a file that grows meanwhile is read as far as fstat saw it
    const ssize_t n = ::read(fd, out.data() + got, out.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw ConfigError(path + ": cannot read file: " + std::strerror(errno));
    if (n == 0) break;
    got += std::size_t(n);
  }
  out.resize(got);
  return out;
}

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
  for (const auto& kv : map) check_key(w, kv.first, known);
}

void check_key(const Where& w, const YAML::Node& key, std::initializer_list<const char*> known) {
  check_key(w, key, std::span<const char* const>(known.begin(), known.size()));
}

void check_key(const Where& w, const YAML::Node& key, std::span<const char* const> known) {
  const std::string k = key.Scalar();
  if (std::any_of(known.begin(), known.end(), [&](const char* x) { return k == x; })) return;
  std::string list;
  for (const char* x : known) list += (list.empty() ? "" : ", ") + std::string(x);
  fail(w.child(k), key, "unknown key (expected one of: " + list + ")");
}

}  // namespace cansim::config
