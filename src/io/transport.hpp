// The outgoing side of one CAN interface as the loop core sees it: a SocketCAN
// socket or a socketcand server in the daemon, a recorder in tests, nothing
// at all in the benchmark.
#pragma once

#include <cstdint>
#include <vector>

#include "core/can_frame.hpp"

namespace cansim::io {

// An outside participant of a bus (LoopCore::submit): a socketcand client, a
// replay. Never 0; at most kMaxParticipant, which is the replays' (a
// socketcand server numbers its clients below it).
using Participant = std::uint32_t;
constexpr Participant kMaxParticipant = 0x7FFFFFFEu;
constexpr Participant kReplayParticipant = kMaxParticipant;

class Transport {
 public:
  virtual ~Transport() = default;
  // Puts a frame a local node sent on the wire. Never blocks; a transport
  // that cannot send queues or drops (and counts) the frame itself.
  virtual void transmit(const CanFrame& frame) = 0;
  // A frame an outside participant sent (LoopCore::submit) is on the wire:
  // everyone but its sender hears it. A kernel interface writes it as any
  // other frame (the default); a socketcand server skips the sender.
  virtual void transmit_from(const CanFrame& frame, Participant /*from*/) { transmit(frame); }
  // A transport that releases frames at given times itself (SO_TXTIME with
  // the ETF qdisc): a timed bus hands it each frame ahead, with the time its
  // EOF ends on the modelled bus (ns of the loop core's clock) and its
  // length there (intermission included: the least it may follow the one
  // before by).
  virtual bool paces() const { return false; }
  // False while nothing carries the frames anywhere (a kernel interface
  // down or missing): they are counted and dropped, so nobody can see when
  // each ended, and a timed bus hands them over ahead in batches as to a
  // pacing transport (one wake-up a batch, not one a frame); its local
  // listeners still hear each at its end (docs/bus-model.md).
  virtual bool carries() const { return true; }
  virtual void transmit_at(const CanFrame& frame, std::int64_t /*end_ns*/, std::int64_t /*length_ns*/) {
    transmit(frame);
  }
  // A frame handed over while it carried nothing is written again now (a
  // timed bus's recall, TimedBus::recall()): a transport that counted it
  // lost then takes that back, as it goes on the wire after all.
  virtual void recalled() {}
  // An error the master's controller reports (fault error_frames, a
  // collision): SocketCAN writes it as a CAN_ERR_FLAG frame, a kernel-free
  // transport as its protocol's error message.
  virtual void error(BusError) {}
};

// Counts frames and forgets them (benchmark, load estimates); `paced`: as
// a kernel-paced interface.
class NullTransport : public Transport {
 public:
  void transmit(const CanFrame&) override { ++frames; }
  void error(BusError) override { ++errors; }
  std::uint64_t errors = 0;
  bool paces() const override { return paced; }
  std::uint64_t frames = 0;
  bool paced = false;
};

// Records every frame with the time the loop core says it is (unit tests).
class MemoryTransport : public Transport {
 public:
  struct Sent {
    TimeUs time;
    CanFrame frame;
    std::int64_t launch_ns = -1;  // paced: the time it was handed over for
  };
  explicit MemoryTransport(const TimeUs* clock = nullptr) : clock_(clock) {}
  void transmit(const CanFrame& frame) override { log.push_back({clock_ ? *clock_ : 0, frame}); }
  bool paces() const override { return paced; }
  bool carries() const override { return carrying; }
  void recalled() override { ++recalled_frames; }
  void transmit_at(const CanFrame& frame, std::int64_t end_ns, std::int64_t) override {
    log.push_back({clock_ ? *clock_ : 0, frame, end_ns});
  }
  struct Error {
    TimeUs time;
    BusError error;
    bool operator==(const Error&) const = default;
  };
  void error(BusError e) override { errors.push_back({clock_ ? *clock_ : 0, e}); }
  std::vector<Error> errors;
  std::vector<Sent> take() {
    std::vector<Sent> out;
    out.swap(log);
    return out;
  }
  std::vector<Sent> log;
  bool paced = false;
  bool carrying = true;  // false: as a kernel interface down
  std::size_t recalled_frames = 0;

 private:
  const TimeUs* clock_;
};

}  // namespace cansim::io
