#pragma once
// A config error is one line of text whatever the file holds: its control
// characters (a NUL, a newline) are written as \xNN. Without this a key with a
// NUL in it would end the message at the NUL (std::exception::what() is a C
// string) and lose the rest of the line.
#include <cstdio>
#include <string>
#include <string_view>

namespace cansim::config {

inline std::string printable(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    const auto b = static_cast<unsigned char>(c);
    if (b >= 0x20 && b != 0x7F) {
      out += c;
      continue;
    }
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02X", b);
    out += buf;
  }
  return out;
}

}  // namespace cansim::config
