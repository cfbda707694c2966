// A node's CAN controller misbehaving on purpose (docs/faults.md):
//
//   babbling      it floods one COB-ID with 8-byte frames at a rate (frames
//                 per second): on a timed bus everything of a higher
//                 identifier starves, a full queue drops frames;
//   error_frames  it makes the master's controller report an error class
//                 (BusError) at the fault's start and every `period`; a
//                 state class ends with its way back (warning / passive:
//                 active, bus-off: restarted).
//
// Frames are due on absolute deadlines (no drift); a late pass sends what is
// due, at most kBurst babbling frames at once. Several faults of one kind
// add up. A value: copies with the node's snapshot; no allocation.
#pragma once

#include <array>
#include <cstdint>

#include "core/can_frame.hpp"

namespace cansim {

class Disturbance {
 public:
  static constexpr std::size_t kMax = 4;
  static constexpr int kBurst = 1024;

  // Starts (or keeps, when already running) fault `id`.
  void babble(std::uint32_t id, const CanFrame& frame, double rate_hz, TimeUs now);
  void error_frames(std::uint32_t id, BusError error, TimeUs period, TimeUs now);
  // Ends fault `id`; an error_frames fault of a state class reports its way back.
  template <typename Error>
  void stop(std::uint32_t id, Error&& error);
  bool running(std::uint32_t id) const;

  // What is due by `now`: send(frame) and error(BusError).
  template <typename Send, typename Error>
  void process(TimeUs now, Send&& send, Error&& error);
  TimeUs next_deadline() const { return n_ ? earliest() : kNever; }

 private:
  struct Source {
    std::uint32_t id = 0;
    bool babbling = false;  // else error frames
    CanFrame frame;
    BusError error = BusError::kStuff;
    std::int64_t period_ns = 0;  // 0: error frames once
    std::int64_t next_ns = 0;
  };
  static BusError way_back(BusError e);
  TimeUs earliest() const;

  std::size_t n_ = 0;  // first: a node reads it at every wake-up
  std::array<Source, kMax> sources_{};
};

template <typename Error>
void Disturbance::stop(std::uint32_t id, Error&& error) {
  for (std::size_t i = 0; i < n_; ++i) {
    if (sources_[i].id != id) continue;
    const Source s = sources_[i];
    sources_[i] = sources_[--n_];
    if (!s.babbling && way_back(s.error) != s.error) error(way_back(s.error));
    return;
  }
}

template <typename Send, typename Error>
void Disturbance::process(TimeUs now, Send&& send, Error&& error) {
  const std::int64_t now_ns = now * 1000;
  for (std::size_t i = 0; i < n_; ++i) {
    Source& s = sources_[i];
    for (int k = 0; s.next_ns <= now_ns && k < kBurst; ++k) {
      if (s.babbling) send(s.frame);
      else error(s.error);
      if (s.period_ns <= 0) {
        s.next_ns = std::numeric_limits<std::int64_t>::max();
        break;
      }
      s.next_ns += s.period_ns;
    }
    // A long pause (power off, a late loop): go on from now, not in a burst.
    if (s.next_ns <= now_ns) s.next_ns = now_ns + s.period_ns;
  }
}

}  // namespace cansim
