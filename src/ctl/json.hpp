// A minimal streaming JSON writer for cansimctl --json (no dependency).
#pragma once

#include <concepts>
#include <cstdint>
#include <ostream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace cansim::ctl {

// The JSON string literal for text, quotes included. Control characters are
// escaped as \uXXXX; bytes >= 0x80 pass through (the text is UTF-8).
std::string json_quote(std::string_view text);

// Writes one JSON value; commas between members and elements are automatic.
// Inside an object, call key() before each member's value.
class JsonWriter {
 public:
  explicit JsonWriter(std::ostream& out) : out_(out) {}

  void begin_object();
  void end_object();
  void begin_array();
  void end_array();
  void key(std::string_view name);

  void value(std::string_view text);
  void value(const char* text) { value(std::string_view(text)); }
  void value(bool b);
  void value(double d);  // NaN and infinities: null
  template <std::integral T>
    requires(!std::same_as<T, bool>)
  void value(T n) {
    if constexpr (std::is_signed_v<T>)
      integer(std::to_string(std::int64_t(n)));
    else
      integer(std::to_string(std::uint64_t(n)));
  }
  void null();

  // key(name) then value(v).
  template <typename T>
  void member(std::string_view name, const T& v) {
    key(name);
    value(v);
  }

 private:
  void before_value();
  void integer(const std::string& digits);

  std::ostream& out_;
  std::vector<bool> first_;  // per open container: no element written yet
  bool after_key_ = false;
};

// An array of objects, one per item; `members(json, item)` writes its members.
template <typename Items, typename Members>
void write_objects(JsonWriter& json, const Items& items, Members members) {
  json.begin_array();
  for (const auto& item : items) {
    json.begin_object();
    members(json, item);
    json.end_object();
  }
  json.end_array();
}

// The same as one JSON document on its own line.
template <typename Items, typename Members>
void print_objects(std::ostream& out, const Items& items, Members members) {
  JsonWriter json(out);
  write_objects(json, items, members);
  out << '\n';
}

}  // namespace cansim::ctl
