// One virtual bus that keeps time (README "The bus model"): the frames local
// nodes send wait in an ArbitrationQueue, the bus takes one at a time for
// its wire_bits() at the bit rate, and each leaves (to the transport and the
// other local nodes) when its last EOF bit is on the wire; the 3 bits of
// intermission follow before the next frame may start. When the bus becomes
// free, the lowest identifier among the frames queued by then wins. A frame
// from outside occupies the bus for its own length from its arrival (after
// the frame on the wire, if one is).
//
// Time on the bus is kept in nanoseconds (a bit is 1 µs at 1 Mbit/s, 1.25 µs
// at 800 kbit/s, 8 µs at 125 kbit/s) and never reset to the caller's clock:
// a late caller gets the frames that ended meanwhile, in order, with the
// schedule unchanged (no drift).
//
// The caller drives it sans I/O, at each instant `now` (µs) it runs:
//   settle(now, kBefore)  frames that started before now and ended by now
//   submit(...)           what its nodes send at now
//   settle(now, kAt)      frames that start at now (the bus free), and end
//   next_event()          when to come back: the end of the next frame
#pragma once

#include <cstdint>
#include <limits>

#include "io/arbitration_queue.hpp"
#include "io/wire_bits.hpp"

namespace cansim::io {

class TimedBus {
 public:
  // kBefore: only frames that started strictly before `now` (frames queued
  // at `now` may still compete); kAt: also the frame starting at `now`.
  enum class Phase : std::uint8_t { kBefore, kAt };

  TimedBus(std::int64_t bit_ns, std::size_t queue_frames) : bit_ns_(bit_ns), queue_(queue_frames) {}

  void set_bit_ns(std::int64_t bit_ns) {
    bit_ns_ = bit_ns;
    next_stale_ = true;
  }
  std::int64_t bit_ns() const { return bit_ns_; }

  // A local node's frame, sent at `now`. False when the queue is full (the
  // frame is dropped and counted).
  bool submit(QueuedFrame q, TimeUs now);
  // A frame from the wire, seen at `now`, occupies the bus for `bits`.
  void occupy(int bits, TimeUs now);
  // The next frame that has ended by `now`, into `done` (its start time in
  // `started_ns`); false when none. Call until false.
  bool settle(TimeUs now, Phase phase, QueuedFrame& done, std::int64_t& started_ns);
  // settle() has nothing to do before this time (ns): the end of the frame
  // on the wire, or when the bus is free for the next.
  std::int64_t due_ns() const {
    return busy_ ? end_ns_ : queue_.empty() ? std::numeric_limits<std::int64_t>::max() : free_ns_;
  }
  // When the frame on the wire, or the one that will win next, ends (µs,
  // rounded up); kNever when nothing is queued.
  TimeUs next_event() const {
    if (next_stale_) refresh_next_event();
    return next_event_;
  }

  std::size_t queued() const { return queue_.size() + (busy_ ? 1 : 0); }
  // Frames taken so far (a mark), and whether one taken before `mark` still
  // waits or is on the wire.
  std::uint64_t taken() const { return taken_; }
  bool holds_before(std::uint64_t mark) const;
  std::size_t capacity() const { return queue_.capacity(); }
  std::uint64_t dropped() const { return dropped_; }
  // Calls fn(QueuedFrame&) for every queued frame, the one on the wire too.
  template <typename Fn>
  void for_each(Fn&& fn) {
    queue_.for_each(fn);
    if (busy_) fn(current_);
  }
  // Takes every frame out at once, in arbitration order (switching to ideal).
  template <typename Fn>
  void drain(Fn&& fn) {
    if (busy_) fn(current_);
    busy_ = false;
    for (; !queue_.empty(); queue_.pop()) fn(queue_.top());
    next_stale_ = true;
  }

 private:
  std::int64_t end_of(std::int64_t start_ns, int bits) const { return start_ns + (bits - kIntermissionBits) * bit_ns_; }
  void refresh_next_event() const;

  std::int64_t bit_ns_;
  ArbitrationQueue queue_;
  std::int64_t free_ns_ = 0;  // the bus is free for the next start (after intermission)
  bool busy_ = false;         // current_ is on the wire
  QueuedFrame current_;
  std::int64_t start_ns_ = 0, end_ns_ = 0;  // of current_
  std::uint64_t dropped_ = 0;
  std::uint64_t taken_ = 0;
  mutable TimeUs next_event_ = kNever;
  mutable bool next_stale_ = false;  // the queue's head may have changed
};

}  // namespace cansim::io
