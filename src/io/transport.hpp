// The outgoing side of one CAN interface as the loop core sees it: a SocketCAN
// socket in the daemon, a recorder in tests, nothing at all in the benchmark.
#pragma once

#include <cstdint>
#include <vector>

#include "core/can_frame.hpp"

namespace cansim::io {

class Transport {
 public:
  virtual ~Transport() = default;
  // Puts a frame on the wire. Never blocks; a transport that cannot send
  // queues or drops (and counts) the frame itself.
  virtual void transmit(const CanFrame& frame) = 0;
};

// Counts frames and forgets them (benchmark, load estimates).
class NullTransport : public Transport {
 public:
  void transmit(const CanFrame&) override { ++frames; }
  std::uint64_t frames = 0;
};

// Records every frame with the time the loop core says it is (unit tests).
class MemoryTransport : public Transport {
 public:
  struct Sent {
    TimeUs time;
    CanFrame frame;
  };
  explicit MemoryTransport(const TimeUs* clock = nullptr) : clock_(clock) {}
  void transmit(const CanFrame& frame) override { log.push_back({clock_ ? *clock_ : 0, frame}); }
  std::vector<Sent> take() {
    std::vector<Sent> out;
    out.swap(log);
    return out;
  }
  std::vector<Sent> log;

 private:
  const TimeUs* clock_;
};

}  // namespace cansim::io
