// Helpers for reading YAML with errors that name file, line, key and what was
// expected ("profiles/dps.yaml:12:5: objects[3].access: expected one of ro, wo,
// rw, rwr, rww, const, got 'rx'").
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <stdexcept>
#include <string>

namespace cansim::config {

struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A YAML node with the file it came from and the key path leading to it.
struct Where {
  std::string file;
  std::string path;
  Where child(const std::string& key) const { return {file, path.empty() ? key : path + "." + key}; }
  Where item(std::size_t i) const { return {file, path + "[" + std::to_string(i) + "]"}; }
};

[[noreturn]] void fail(const Where& w, const YAML::Node& n, const std::string& expected);

YAML::Node load_yaml_file(const std::string& path);
// `text` read as a YAML document; a syntax error names `file`, line and column.
YAML::Node load_yaml_text(const std::string& text, const std::string& file);

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

}  // namespace cansim::config
