// One virtual bus that keeps time (docs/bus-model.md): the frames local
// nodes send wait in an ArbitrationQueue, the bus takes one at a time for
// its wire_bits() at the bit rate, and each leaves (to the transport and the
// other local nodes) when its last EOF bit is on the wire; the 3 bits of
// intermission follow before the next frame may start. When the bus becomes
// free, the lowest identifier among the frames queued by then wins.
//
// Time on the bus is kept in nanoseconds (a bit is 1 µs at 1 Mbit/s, 1.25 µs
// at 800 kbit/s, 8 µs at 125 kbit/s). The wire never goes faster than
// physics: no frame leaves less than its own length after the one before.
// A frame the caller settles later than its end (a late loop wake-up, more
// than the microsecond its deadline is rounded to) leaves then, and the bus
// slips: the next frames follow from there, each for its length; the slip
// is reported per frame (Departure::slip_ns). Arbitration, lengths and the
// nodes' own deadlines are unchanged by it.
//
// Frames from outside (occupy()) were on the wire before cansimd saw them:
// each holds the bus for its own length from its arrival, after our frame on
// the wire if one is. Outside frames overlap each other: a flood faster than
// the bit rate keeps the bus busy but never pushes its time more than one
// frame ahead of the clock (beyond our frame on the wire), so our frames go
// out within a frame time of the flood's end. occupy() returns the wire time
// the frame added (what the meter counts as carried).
//
// Two transmitters at one place (a node and its twin, fault
// node_id_collision) may start frames of one identifier at once, both
// waiting when the bus became free. Identical frames are one frame on the
// wire (both acknowledged). Different ones collide (ISO 11898-1 §12.1.4):
// both win arbitration and diverge at the first differing bit; the one
// sending recessive there sees a bit error and signals an error frame; both
// retry and collide again, each error adding 8 to both transmit error
// counters, until after kCollisionAttempts (16) both are error passive: the
// loser's passive error flag no longer destroys the frame, the one with the
// dominant bit completes, the other follows it. Modelled: the 16 attempts'
// wire time (up to the differing bit, then an error frame) before the
// winner, the loser next in arbitration; the local nodes' own error
// counters and states are not (docs/bus-model.md).
//
// Two pacers:
//   kLoop    the caller writes each frame when it ends: settle() yields it
//            then, one caller wake-up per frame (Departure::launched false);
//   kAhead   the transport releases frames at given times itself (SO_TXTIME
//            and the ETF qdisc): settle() yields each frame once its start is
//            within `horizon` of now (launched true, end_ns its launch time);
//            frames local nodes must hear are handed back with heard() at
//            their end. The caller wakes when the schedule handed over runs
//            shorter than `horizon - batch`, so one wake-up hands over a
//            batch. A frame queued after others were handed over cannot win
//            against them (at most `horizon` of frames).
//
// The caller drives it sans I/O, at each instant `now` (µs) it runs:
//   settle(now, kBefore)  frames that started before now and ended by now
//   submit(...)           what its nodes send at now
//   settle(now, kAt)      frames that start at now (the bus free), and end
//   next_event()          when to come back
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "io/arbitration_queue.hpp"
#include "io/wire_bits.hpp"

namespace cansim::io {

// A frame the bus let go.
struct Departure {
  QueuedFrame q;
  std::int64_t start_ns = 0;  // SOF on the wire
  std::int64_t end_ns = 0;    // end of EOF: written (kLoop) or launched (kAhead), heard
  std::int64_t slip_ns = 0;   // how much later than the schedule it leaves
  bool launched = false;      // kAhead: handed over ahead of end_ns
  bool recalled = false;      // handed over to nobody: the caller writes it now (recall())
  int collisions = 0;         // attempts destroyed by a collision before it (kCollisionAttempts)
  int collision_bits = 0;     // the wire time they took
};

enum class Pacer : std::uint8_t { kLoop, kAhead };

class TimedBus {
 public:
  // kBefore: only frames that started strictly before `now` (frames queued
  // at `now` may still compete); kAt: also the frame starting at `now`.
  enum class Phase : std::uint8_t { kBefore, kAt };
  static constexpr std::int64_t kDefaultHorizonNs = 4'000'000;
  static constexpr std::int64_t kDefaultBatchNs = 3'000'000;

  TimedBus(std::int64_t bit_ns, std::size_t queue_frames);

  void set_bit_ns(std::int64_t bit_ns) {
    bit_ns_ = bit_ns;
    next_stale_ = true;
  }
  std::int64_t bit_ns() const { return bit_ns_; }
  void set_pacer(Pacer pacer, std::int64_t horizon_ns = kDefaultHorizonNs, std::int64_t batch_ns = kDefaultBatchNs);
  // The frames handed over that have not ended are recalled: settle()
  // yields each again at its end (Departure::recalled), for the caller to
  // write then. The transport they were handed to carried nothing (an
  // interface down, Transport::carries()) and now does.
  void recall() {
    recalled_ = flight_.size();
    next_stale_ = true;
  }
  Pacer pacer() const { return pacer_; }

  // A local node's frame, sent at `now`. False when the queue is full (the
  // frame is dropped and counted).
  bool submit(QueuedFrame q, TimeUs now);
  // A frame from the wire, seen at `now`, occupies the bus for `bits`;
  // returns the bits of wire time it added.
  int occupy(int bits, TimeUs now);
  // The next frame that leaves by `now`, into `d`; false when none. Call
  // until false.
  bool settle(TimeUs now, Phase phase, Departure& d);
  // kAhead: local nodes hear `d` (a launched frame) at its end: heard()
  // hands it back then.
  bool hear_at_end(const Departure& d);
  bool heard(TimeUs now, Departure& d);
  // settle() / heard() have nothing to do before this time (ns).
  std::int64_t due_ns() const;
  // When to come back (µs, rounded up); kNever when nothing waits.
  TimeUs next_event() const {
    if (next_stale_) refresh_next_event();
    return next_event_;
  }

  // Frames waiting, on the wire, or launched and not yet ended.
  std::size_t queued() const { return queue_.size() + (busy_ ? 1 : 0) + flight_.size(); }
  // Frames taken so far (a mark), and whether one taken before `mark` still
  // waits or is on the wire (launched: until its end).
  std::uint64_t taken() const { return taken_; }
  bool holds_before(std::uint64_t mark) const;
  std::size_t capacity() const { return queue_.capacity(); }
  // Frames of babbling controllers (FrameSink::kBabbler) waiting: each
  // keeps its transmit buffer full, kBabbleBuffer frames.
  static constexpr std::size_t kBabbleBuffer = 2;
  std::size_t babbling() const { return babbling_; }
  std::uint64_t dropped() const { return dropped_; }
  std::uint64_t merged() const { return merged_; }  // identical frames of two transmitters sent as one
  static constexpr int kCollisionAttempts = 16;
  // Takes out the queued frames (not the one on the wire, nor those
  // launched) for which pred(const QueuedFrame&) is true: a controller's
  // transmit buffer cleared. Returns how many.
  template <typename Pred>
  std::size_t withdraw(Pred&& pred) {
    const std::size_t n = queue_.remove_if(pred);
    next_stale_ |= n > 0;
    return n;
  }
  // Calls fn(QueuedFrame&) for every frame not yet ended.
  template <typename Fn>
  void for_each(Fn&& fn) {
    queue_.for_each(fn);
    if (busy_) fn(current_.q);
    flight_.for_each([&](Flight& f) { fn(f.q); });
    heard_.for_each([&](Departure& d) { fn(d.q); });
  }
  // Takes every frame out at once (switching to ideal), in the order they
  // would have ended: the recalled ones to write(const QueuedFrame&), the
  // launched ones local nodes hear to hear(const Departure&) (the other
  // launched frames are the transport's already), then the one on the wire
  // and the queue in arbitration order to fn(const QueuedFrame&).
  template <typename Write, typename Hear, typename Fn>
  void drain(Write&& write, Hear&& hear, Fn&& fn) {
    for (; recalled_ > 0; --recalled_, flight_.pop()) write(flight_.front().q);
    heard_.for_each([&](const Departure& d) { hear(d); });
    if (busy_) fn(current_.q);
    busy_ = false;
    for (; !queue_.empty(); queue_.pop()) fn(queue_.top());
    flight_.clear();
    heard_.clear();
    babbling_ = 0;
    next_stale_ = true;
  }

 private:
  // A bounded FIFO allocated once.
  template <typename T>
  class Ring {
   public:
    explicit Ring(std::size_t n) : items_(n) {}
    bool push(const T& t) {
      if (n_ == items_.size()) return false;
      items_[(head_ + n_++) % items_.size()] = t;
      return true;
    }
    bool empty() const { return n_ == 0; }
    std::size_t size() const { return n_; }
    const T& front() const { return items_[head_]; }
    const T& back() const { return items_[(head_ + n_ - 1) % items_.size()]; }
    void pop() {
      head_ = (head_ + 1) % items_.size();
      --n_;
    }
    void clear() { head_ = n_ = 0; }
    template <typename Fn>
    void for_each(Fn&& fn) {
      for (std::size_t i = 0; i < n_; ++i) fn(items_[(head_ + i) % items_.size()]);
    }
    template <typename Fn>
    void for_each(Fn&& fn) const {
      for (std::size_t i = 0; i < n_; ++i) fn(items_[(head_ + i) % items_.size()]);
    }

   private:
    std::vector<T> items_;
    std::size_t head_ = 0, n_ = 0;
  };
  struct Flight {  // launched, not yet ended
    QueuedFrame q;
    std::int64_t end_ns;
  };

  std::int64_t end_of(std::int64_t start_ns, int bits) const { return start_ns + (bits - kIntermissionBits) * bit_ns_; }
  std::int64_t next_start_of(const QueuedFrame& q) const { return std::max(free_ns_, q.queued_at * 1000); }
  // The start of the frame that wins next (queue not empty).
  std::int64_t next_start() const { return next_start_of(queue_.top()); }
  // heard() and the end of the last launched frame.
  std::int64_t flight_due_ns() const;
  bool leave_wire(std::int64_t now_ns, Departure& d);
  bool settle_loop(std::int64_t now_ns, Phase phase, Departure& d);
  bool settle_ahead(std::int64_t now_ns, Phase phase, Departure& d);
  void take(Departure& d);  // the winner, from the queue onto the wire
  void collide(Departure& d);
  void refresh_next_event() const;

  std::int64_t bit_ns_;
  Pacer pacer_ = Pacer::kLoop;
  std::int64_t horizon_ns_ = kDefaultHorizonNs;
  std::int64_t batch_ns_ = kDefaultBatchNs;
  ArbitrationQueue queue_;
  std::int64_t free_ns_ = 0;  // the bus is free for the next start (after intermission)
  bool busy_ = false;         // kLoop: current_ is on the wire
  Departure current_;
  Ring<Flight> flight_;       // kAhead: launched, for queued() and holds_before()
  std::size_t recalled_ = 0;  // the first of them, handed over to nobody (recall())
  Ring<Departure> heard_;     // kAhead: launched frames local nodes hear at their end
  std::uint64_t dropped_ = 0;
  std::uint64_t merged_ = 0;
  std::size_t babbling_ = 0;
  std::uint64_t taken_ = 0;
  mutable TimeUs next_event_ = kNever;
  mutable bool next_stale_ = false;  // the queue's head may have changed
};

}  // namespace cansim::io
