#include "ctl/candump.hpp"

#include <linux/can.h>

#include <charconv>
#include <cmath>
#include <cstdio>

namespace cansim::ctl {

namespace {

constexpr std::uint32_t kErrorFlag = CAN_ERR_FLAG;

bool hex_value(std::string_view s, std::uint32_t& v) {
  if (s.empty()) return false;
  auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v, 16);
  return ec == std::errc{} && end == s.data() + s.size();
}

std::string_view next_word(std::string_view& s) {
  const std::size_t a = s.find_first_not_of(" \t");
  if (a == std::string_view::npos) return s = {}, std::string_view{};
  const std::size_t b = s.find_first_of(" \t", a);
  std::string_view w = s.substr(a, b == std::string_view::npos ? std::string_view::npos : b - a);
  s.remove_prefix(b == std::string_view::npos ? s.size() : b);
  return w;
}

bool parse_time(std::string_view w, std::int64_t& us) {
  if (w.size() < 3 || w.front() != '(' || w.back() != ')') return false;
  w = w.substr(1, w.size() - 2);
  const std::size_t dot = w.find('.');
  std::int64_t sec = 0, frac = 0;
  const std::string_view s = w.substr(0, dot), f = dot == std::string_view::npos ? "" : w.substr(dot + 1);
  if (s.empty() || f.size() > 9) return false;
  if (std::from_chars(s.data(), s.data() + s.size(), sec).ptr != s.data() + s.size()) return false;
  if (!f.empty() && std::from_chars(f.data(), f.data() + f.size(), frac).ptr != f.data() + f.size()) return false;
  for (std::size_t i = f.size(); i < 6; ++i) frac *= 10;
  for (std::size_t i = 6; i < f.size(); ++i) frac /= 10;
  us = sec * 1000000 + frac;
  return true;
}

}  // namespace

std::string candump_line(const RawFrame& f) {
  const std::int64_t us = std::llround(f.time * 1e6);
  char head[64];
  std::snprintf(head, sizeof head, "(%lld.%06lld) ", static_cast<long long>(us / 1000000),
                static_cast<long long>(us % 1000000));
  std::string out = head + f.interface + ' ';
  char id[16];
  if (f.error) std::snprintf(id, sizeof id, "%08X#", f.id | kErrorFlag);
  else if (f.extended) std::snprintf(id, sizeof id, "%08X#", f.id & 0x1FFFFFFFu);
  else std::snprintf(id, sizeof id, "%03X#", f.id & 0x7FFu);
  out += id;
  if (f.rtr && !f.error) {
    out += 'R';
    if (f.dlc) out += char('0' + (f.dlc > 8 ? 8 : f.dlc));
  } else {
    static constexpr char kHex[] = "0123456789ABCDEF";
    for (std::uint8_t i = 0; i < f.dlc && i < 8; ++i) out += kHex[f.data[i] >> 4], out += kHex[f.data[i] & 0xF];
  }
  return out + '\n';
}

bool parse_candump_line(std::string_view line, std::int64_t& time_us, RawFrame& frame, std::string& why) {
  why.clear();
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.remove_suffix(1);
  std::string_view rest = line;
  const std::string_view stamp = next_word(rest);
  if (stamp.empty() || stamp.front() == '#') return false;
  const std::string_view iface = next_word(rest), text = next_word(rest);
  if (!parse_time(stamp, time_us) || iface.empty() || text.empty()) {
    why = "expected (SECONDS.MICROSECONDS) INTERFACE ID#DATA";
    return false;
  }
  const std::size_t hash = text.find('#');
  std::uint32_t id = 0;
  if (hash == std::string_view::npos || !hex_value(text.substr(0, hash), id) || (hash != 3 && hash != 8)) {
    why = "expected ID#DATA with an identifier of 3 or 8 hex digits";
    return false;
  }
  std::string_view data = text.substr(hash + 1);
  if (!data.empty() && data.front() == '#') {
    why = "not replayed: a CAN FD frame";
    return false;
  }
  if (hash == 8 && (id & kErrorFlag)) {
    why = "not replayed: an error frame";
    return false;
  }
  frame = RawFrame{};
  frame.time = double(time_us) / 1e6;
  frame.interface = std::string(iface);
  frame.id = id & (hash == 8 ? 0x1FFFFFFFu : 0x7FFu);
  frame.extended = hash == 8;
  if (hash == 3 && id > 0x7FF) {
    why = "an 11-bit identifier above 7FF";
    return false;
  }
  if (!data.empty() && (data.front() == 'R' || data.front() == 'r')) {
    frame.rtr = true;
    std::uint32_t dlc = 0;
    if (data.size() > 2 || (data.size() == 2 && (!hex_value(data.substr(1), dlc) || dlc > 8))) {
      why = "expected R or R0..R8 for a remote frame";
      return false;
    }
    frame.dlc = std::uint8_t(dlc);
    return true;
  }
  if (data.size() % 2 || data.size() > 16) {
    why = "expected 0 to 8 data bytes as pairs of hex digits";
    return false;
  }
  for (std::size_t i = 0; i < data.size(); i += 2) {
    std::uint32_t b = 0;
    if (!hex_value(data.substr(i, 2), b)) {
      why = "expected 0 to 8 data bytes as pairs of hex digits";
      return false;
    }
    frame.data[frame.dlc++] = std::uint8_t(b);
  }
  return true;
}

}  // namespace cansim::ctl
