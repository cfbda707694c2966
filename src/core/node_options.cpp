#include "core/node_options.hpp"

#include <cstdlib>

namespace cansim {

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
