// CAN frames and time as the protocol core sees them. The core never touches
// sockets or clocks: frames come in through Node::on_frame, go out through a
// FrameSink, and time is passed in by the caller (Lely-style, sans I/O).
#pragma once

#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <limits>

namespace cansim {

// Monotonic time in microseconds. The epoch is whatever the caller uses.
using TimeUs = std::int64_t;
constexpr TimeUs kNever = std::numeric_limits<TimeUs>::max();
constexpr TimeUs ms(std::int64_t v) { return v * 1000; }

struct CanFrame {
  static constexpr std::uint8_t kRtr = 0x01;
  static constexpr std::uint8_t kExtended = 0x02;  // 29-bit identifier

  std::uint32_t id = 0;
  std::uint8_t dlc = 0;
  std::uint8_t flags = 0;
  std::uint8_t data[8] = {};

  bool rtr() const { return flags & kRtr; }
  bool extended() const { return flags & kExtended; }

  static CanFrame make(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
    CanFrame f;
    f.id = id;
    for (std::uint8_t b : bytes) {
      if (f.dlc == 8) break;
      f.data[f.dlc++] = b;
    }
    return f;
  }
  static CanFrame remote(std::uint32_t id, std::uint8_t dlc = 0) {
    CanFrame f;
    f.id = id;
    f.dlc = dlc;
    f.flags = kRtr;
    return f;
  }
  bool operator==(const CanFrame& o) const {
    return id == o.id && dlc == o.dlc && flags == o.flags &&
           (rtr() || std::memcmp(data, o.data, dlc) == 0);
  }
};

// The error state of a CAN controller (ISO 11898-1 fault confinement; error
// warning: a counter reached 96, as SocketCAN reports it).
enum class CanState : std::uint8_t { kErrorActive, kErrorWarning, kErrorPassive, kBusOff };

// Where a node's outgoing frames go (a socket, an in-memory bus, a test recorder).
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  virtual void send(const CanFrame& frame) = 0;
};

inline std::uint16_t get_u16(const std::uint8_t* p) { return std::uint16_t(p[0] | (p[1] << 8)); }
inline std::uint32_t get_u32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) |
         (std::uint32_t(p[3]) << 24);
}
inline void put_u16(std::uint8_t* p, std::uint16_t v) {
  p[0] = std::uint8_t(v);
  p[1] = std::uint8_t(v >> 8);
}
inline void put_u32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = std::uint8_t(v >> (8 * i));
}

}  // namespace cansim
