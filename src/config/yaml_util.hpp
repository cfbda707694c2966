// Helpers for reading YAML with errors that name file, line, key and what was
// expected ("profiles/dps.yaml:12:5: objects[3].access: expected one of ro, wo,
// rw, rwr, rww, const, got 'rx'").
#pragma once

#include <yaml-cpp/yaml.h>

#include "config/printable.hpp"

#include <cstdint>
#include <stdexcept>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace cansim::config {

// One line of text whatever the file held: its control characters are \xNN
// (printable.hpp), so a NUL in a key does not end what() early.
struct ConfigError : std::runtime_error {
  explicit ConfigError(const std::string& message) : std::runtime_error(printable(message)) {}
};
// Input over a bound of config/limits.hpp (the control API answers
// io.cansim.Error.TooLarge).
struct TooLarge : ConfigError {
  using ConfigError::ConfigError;
};

// A YAML node with the file it came from and the key path leading to it.
struct Where {
  std::string file;
  std::string path;
  Where child(const std::string& key) const { return {file, path.empty() ? key : path + "." + key}; }
  Where item(std::size_t i) const { return {file, path + "[" + std::to_string(i) + "]"}; }
};

[[noreturn]] void fail(const Where& w, const YAML::Node& n, const std::string& expected);
// The same as TooLarge: `n` is over a bound of config/limits.hpp.
[[noreturn]] void fail_too_large(const Where& w, const YAML::Node& n, const std::string& bound);

// Both check the text's nesting (limits::kYamlDepth) before parsing; a file
// is read as read_regular_file(path, limits::kProfileFileBytes) reads it.
YAML::Node load_yaml_file(const std::string& path);
// `text` read as a YAML document; a syntax error names `file`, line and column.
YAML::Node load_yaml_text(const std::string& text, const std::string& file);

// A cheap upper bound of a YAML text's nesting depth, without parsing it:
// block indentation levels (and compact "- " / "? " entries) plus open flow
// brackets, outside quoted scalars, block scalars and comments. Counting
// stops above `stop_above`. `aliases` (when given) receives the number of
// aliases (*name) seen.
int yaml_depth(std::string_view text, int stop_above, std::size_t* aliases = nullptr);
// The same with the places a bound's error names (offsets into the text).
struct YamlScan {
  int depth = 0;
  std::size_t aliases = 0;
  std::size_t last_alias = 0;  // where the last alias seen starts
  std::size_t end = 0;         // the node that went deeper than stop_above (else the text's size)
};
YamlScan scan_yaml(std::string_view text, int stop_above);
// Throws TooLarge naming `source` when `text` is longer than `max_bytes`,
// nests deeper than limits::kYamlDepth or has more than limits::kYamlAliases
// aliases: what a client sends is checked so, before yaml-cpp (whose memory
// grows with the nesting) sees it. (Files are checked for their nesting.)
void check_yaml_size(std::string_view text, const std::string& source, std::size_t max_bytes);

// True when `file` (symbolic links resolved) lies in one of `dirs`; false
// for a file that does not exist (the answer says nothing of existence).
bool inside_any(const std::string& file, const std::vector<std::string>& dirs);

// While one lives, a file a YAML text names to be read (a `csv:` table) must
// lie in one of `folders` (inside_any) or it is refused by its name alone,
// unopened: what a client sends (AddNodes, SetModel) reads nothing outside
// the profile folders and learns nothing of a file there (its size, its
// existence). Scopes nest (the inner one counts); the loader is one thread.
class ConfinedFiles {
 public:
  explicit ConfinedFiles(std::vector<std::string> folders);
  ~ConfinedFiles();
  ConfinedFiles(const ConfinedFiles&) = delete;
  ConfinedFiles& operator=(const ConfinedFiles&) = delete;
  // The folders in force, or nullptr when files are not confined.
  static const std::vector<std::string>* current();

 private:
  std::vector<std::string> folders_;
  const ConfinedFiles* outer_;
};

// While one lives, every table file a parse reads (a `csv:` table) is noted
// with its text: what a profile depends on besides its own file (a reload
// tells an edited table by it, config::ProfileStore checks it again before
// it hands a parsed profile out). Scopes nest (the inner one notes).
class FilesRead {
 public:
  FilesRead();
  ~FilesRead();
  FilesRead(const FilesRead&) = delete;
  FilesRead& operator=(const FilesRead&) = delete;
  static void note(const std::string& path, const std::string& text);  // nothing when none lives
  const std::vector<std::pair<std::string, std::string>>& files() const { return files_; }

 private:
  std::vector<std::pair<std::string, std::string>> files_;  // path, text
  FilesRead* outer_;
};

// A file's bytes, read without blocking the loop: opened O_NONBLOCK, refused
// unless a regular file (a FIFO or device would block or never end), at most
// `max_bytes` (TooLarge above). Other errors throw ConfigError naming `path`.
std::string read_regular_file(const std::string& path, std::size_t max_bytes);

// Scalars. Integers accept decimal, 0x hex, 0b binary and '_' separators.
std::int64_t get_int(const Where& w, const YAML::Node& n, std::int64_t lo, std::int64_t hi);
std::uint64_t get_uint(const Where& w, const YAML::Node& n);
double get_double(const Where& w, const YAML::Node& n);
bool get_bool(const Where& w, const YAML::Node& n);  // true/false/yes/no
std::string get_string(const Where& w, const YAML::Node& n);

// Parses an integer literal; false if the text is not one.
bool parse_int_literal(const std::string& text, std::int64_t& out);

// Rejects keys of a map that are not in `known` (nullptr-terminated list).
void check_keys(const Where& w, const YAML::Node& map, std::initializer_list<const char*> known);
// The same for one key of the map at `w`.
void check_key(const Where& w, const YAML::Node& key, std::initializer_list<const char*> known);
void check_key(const Where& w, const YAML::Node& key, std::span<const char* const> known);

}  // namespace cansim::config
