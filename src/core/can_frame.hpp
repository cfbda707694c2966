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
    return id == o.id && dlc == o.dlc && flags == o.flags && (rtr() || std::memcmp(data, o.data, dlc) == 0);
  }
};

// One bit at a CiA 305 bit-rate index (Table 1: 1000, 800, 500, 250, 125,
// reserved, 50, 20, 10 kbit/s), in ns; 0: no such rate.
constexpr std::int64_t bit_time_ns(std::uint8_t cia305_index) {
  constexpr std::int64_t kBitNs[] = {1000, 1250, 2000, 4000, 8000, 0, 20000, 50000, 100000};
  return cia305_index < sizeof kBitNs / sizeof kBitNs[0] ? kBitNs[cia305_index] : 0;
}

// The error state of a CAN controller (ISO 11898-1 fault confinement; error
// warning: a counter reached 96, as SocketCAN reports it).
enum class CanState : std::uint8_t { kErrorActive, kErrorWarning, kErrorPassive, kBusOff };

// Which frames a FrameSink::withdraw() concerns.
class FrameFilter {
 public:
  virtual bool matches(const CanFrame& frame) const = 0;

 protected:
  ~FrameFilter() = default;
};

// A CAN error as a master's CAN controller reports it (SocketCAN's error
// frame classes, docs/faults.md "error_frames"); each transport maps it to
// its own form (CAN_ERR_FLAG frames on SocketCAN).
enum class BusError : std::uint8_t {
  kWarning,    // a controller error counter reached 96
  kPassive,    // ... 128: error passive
  kBusOff,     // ... 256: bus-off
  kRestarted,  // the controller restarted after bus-off
  kActive,     // back to error active
  kStuff,      // a stuff error on the bus (six equal bits)
  kForm,       // a form error (a fixed-form bit wrong)
  kAck,        // a frame no node acknowledged
};
// The protocol errors take wire time (an error frame); the others are the
// controller's state.
constexpr bool on_the_wire(BusError e) { return e == BusError::kStuff || e == BusError::kForm || e == BusError::kAck; }

// Where a node's outgoing frames go (a socket, an in-memory bus, a test recorder).
class FrameSink {
 public:
  // The node's own controller; others send at its place: its twin (fault
  // node_id_collision), a babbling controller (fault babbling).
  static constexpr std::uint8_t kOwn = 0, kTwin = 1, kBabbler = 2;

  virtual ~FrameSink() = default;
  virtual void send(const CanFrame& frame) = 0;
  virtual void send_from(const CanFrame& frame, std::uint8_t /*controller*/) { send(frame); }
  // The node's CAN controller clears (a reset, power-off) or loses part of
  // its transmit buffer: frames sent earlier that `filter` matches and
  // that are not on the wire yet never leave (a timed bus's queue).
  virtual void withdraw(const FrameFilter& /*filter*/, std::uint8_t /*controller*/ = kOwn) {}
  // An error for the master's controller to report (fault error_frames):
  // never heard by the local nodes.
  virtual void error(BusError) {}
};

inline std::uint16_t get_u16(const std::uint8_t* p) { return std::uint16_t(p[0] | (p[1] << 8)); }
inline std::uint32_t get_u32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) | (std::uint32_t(p[3]) << 24);
}
inline void put_u16(std::uint8_t* p, std::uint16_t v) {
  p[0] = std::uint8_t(v);
  p[1] = std::uint8_t(v >> 8);
}
inline void put_u32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = std::uint8_t(v >> (8 * i));
}

}  // namespace cansim
