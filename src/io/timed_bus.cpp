#include "io/timed_bus.hpp"

#include <algorithm>

namespace cansim::io {

namespace {
TimeUs ceil_us(std::int64_t ns) { return (ns + 999) / 1000; }
constexpr std::int64_t kNeverNs = std::numeric_limits<std::int64_t>::max();
// A loop deadline is the frame's end rounded up to the µs: a caller that
// comes then is on time; one that comes a µs later woke late.
constexpr std::int64_t kLateNs = 1000;
}  // namespace

TimedBus::TimedBus(std::int64_t bit_ns, std::size_t queue_frames)
    : bit_ns_(bit_ns), queue_(queue_frames), flight_(queue_.capacity()), heard_(queue_.capacity()) {}

void TimedBus::set_pacer(Pacer pacer, std::int64_t horizon_ns, std::int64_t batch_ns) {
  pacer_ = pacer;
  horizon_ns_ = std::max<std::int64_t>(horizon_ns, 0);
  batch_ns_ = std::clamp<std::int64_t>(batch_ns, 0, horizon_ns_);
  next_stale_ = true;
}

bool TimedBus::submit(QueuedFrame q, TimeUs) {
  q.order = taken_;
  if (!queue_.push(q)) {
    ++dropped_;
    return false;
  }
  ++taken_;
  babbling_ += q.controller == FrameSink::kBabbler;
  next_stale_ |= !busy_;
  return true;
}

bool TimedBus::holds_before(std::uint64_t mark) const {
  bool holds = busy_ && current_.q.order < mark;
  queue_.for_each([&](const QueuedFrame& q) { holds |= q.order < mark; });
  flight_.for_each([&](const Flight& f) { holds |= f.q.order < mark; });
  return holds;
}

int TimedBus::occupy(int bits, TimeUs now) {
  const std::int64_t now_ns = now * 1000;
  // After our frame on the wire; over other outside frames (they overlap).
  const std::int64_t from = busy_ ? std::max(now_ns, current_.start_ns + current_.q.bits * bit_ns_) : now_ns;
  const std::int64_t to = from + bits * bit_ns_;
  const std::int64_t added = std::max<std::int64_t>(0, to - std::max(free_ns_, from));
  free_ns_ = std::max(free_ns_, to);
  next_stale_ = true;
  return bit_ns_ > 0 ? int(added / bit_ns_) : 0;
}

void TimedBus::take(Departure& d) {
  d.q = queue_.top();
  queue_.pop();
  d.start_ns = next_start_of(d.q);
  d.slip_ns = 0;
  d.launched = false;
  d.collisions = d.collision_bits = 0;
  babbling_ -= d.q.controller == FrameSink::kBabbler;
  collide(d);
  d.end_ns = end_of(d.start_ns, d.q.bits);
  free_ns_ = d.start_ns + d.q.bits * bit_ns_;
}

namespace {
// The bits from SOF through the data field, before stuffing (arbitration,
// control, data): where two frames of one identifier first differ.
int first_difference(const CanFrame& a, const CanFrame& b, bool& a_dominant) {
  const int dlc_at = a.extended() ? 35 : 15;
  for (int i = 3; i >= 0; --i)
    if (((a.dlc >> i) ^ (b.dlc >> i)) & 1) {
      a_dominant = !((a.dlc >> i) & 1);
      return dlc_at + 3 - i;
    }
  for (int byte = 0; byte < std::min<int>(a.dlc, 8); ++byte)
    for (int i = 7; i >= 0; --i)
      if (((a.data[byte] >> i) ^ (b.data[byte] >> i)) & 1) {
        a_dominant = !((a.data[byte] >> i) & 1);
        return dlc_at + 4 + byte * 8 + 7 - i;
      }
  return -1;
}
}  // namespace

// The other transmitter at the winner's place starts the same identifier at
// once: one frame, or a collision (see the header).
void TimedBus::collide(Departure& d) {
  if (queue_.empty()) return;
  const QueuedFrame& other = queue_.top();
  if (other.from != d.q.from || other.controller == d.q.controller || other.queued_at * 1000 > d.start_ns ||
      ArbitrationQueue::key(other.frame) != ArbitrationQueue::key(d.q.frame))
    return;
  bool winner_dominant = true;
  const int at = d.q.frame.rtr() ? -1 : first_difference(d.q.frame, other.frame, winner_dominant);
  if (at < 0) {  // the same bits: one frame on the wire
    queue_.pop();
    ++merged_;
    return;
  }
  if (!winner_dominant) {  // the other one completes first; this one follows it
    const QueuedFrame loser = d.q;
    d.q = other;
    queue_.pop();
    queue_.push(loser);
  }
  d.collisions = kCollisionAttempts;
  d.collision_bits = kCollisionAttempts * (at + 1 + kErrorFrameBits);
  d.start_ns += d.collision_bits * bit_ns_;
}

bool TimedBus::settle(TimeUs now, Phase phase, Departure& d) {
  const std::int64_t now_ns = now * 1000;
  while (!flight_.empty() && flight_.front().end_ns <= now_ns) {
    const Flight f = flight_.front();
    flight_.pop();
    next_stale_ = true;
    if (recalled_ > 0) {
      --recalled_;
      d = Departure{};
      d.q = f.q;
      d.end_ns = f.end_ns;
      d.recalled = true;
      return true;
    }
  }
  if (busy_) return leave_wire(now_ns, d);
  return pacer_ == Pacer::kLoop ? settle_loop(now_ns, phase, d) : settle_ahead(now_ns, phase, d);
}

// The frame on the wire leaves at its end, whatever the pacer is by then
// (it may have changed since the loop's pacer took it).
bool TimedBus::leave_wire(std::int64_t now_ns, Departure& d) {
  if (current_.end_ns > now_ns) return false;
  busy_ = false;
  next_stale_ = true;
  d = current_;
  d.slip_ns = now_ns - d.end_ns >= kLateNs ? now_ns - d.end_ns : 0;
  // It leaves now: the next frame follows it from here.
  if (d.slip_ns) free_ns_ = std::max(free_ns_, now_ns + kIntermissionBits * bit_ns_);
  return true;
}

bool TimedBus::settle_loop(std::int64_t now_ns, Phase phase, Departure& d) {
  for (;;) {
    if (busy_) return leave_wire(now_ns, d);
    if (queue_.empty()) return false;
    // Arbitration when the bus is free: before `now` only among the frames
    // queued earlier (every frame queued then was there by free_ns_), at
    // `now` among those queued at `now` too.
    if (phase == Phase::kBefore ? free_ns_ >= now_ns : free_ns_ > now_ns) return false;
    take(current_);
    busy_ = true;
    next_event_ = ceil_us(current_.end_ns);
    next_stale_ = false;
  }
}

// Frames handed over start no earlier than the moment they are: a caller
// that comes late (the schedule handed over ran out) slips the bus.
bool TimedBus::settle_ahead(std::int64_t now_ns, Phase phase, Departure& d) {
  if (phase == Phase::kBefore || queue_.empty()) return false;
  if (next_start() > now_ns + horizon_ns_ || flight_.size() == queue_.capacity()) return false;
  const std::int64_t scheduled = next_start();
  take(d);
  if (scheduled < now_ns) {
    d.slip_ns = now_ns - scheduled;
    d.start_ns = now_ns;
    d.end_ns = end_of(now_ns, d.q.bits);
    free_ns_ = now_ns + d.q.bits * bit_ns_;
  }
  d.launched = true;
  flight_.push({d.q, d.end_ns});
  next_stale_ = true;
  return true;
}

bool TimedBus::hear_at_end(const Departure& d) {
  next_stale_ = true;
  return heard_.push(d);
}

bool TimedBus::heard(TimeUs now, Departure& d) {
  if (heard_.empty() || heard_.front().end_ns > now * 1000) return false;
  d = heard_.front();
  heard_.pop();
  next_stale_ = true;
  return true;
}

std::int64_t TimedBus::flight_due_ns() const {
  const std::int64_t heard = heard_.empty() ? kNeverNs : heard_.front().end_ns;
  if (recalled_ > 0) return std::min(heard, flight_.front().end_ns);  // before the last's end
  // At the end of the last launched frame, queued() and holds_before() follow.
  return std::min(heard, flight_.empty() ? kNeverNs : flight_.back().end_ns);
}

std::int64_t TimedBus::due_ns() const {
  std::int64_t due = kNeverNs;
  if (busy_) due = current_.end_ns;  // kAhead too, after a switch from kLoop
  else if (!queue_.empty()) due = pacer_ == Pacer::kLoop ? free_ns_ : next_start() - (horizon_ns_ - batch_ns_);
  return std::min(due, flight_due_ns());
}

void TimedBus::refresh_next_event() const {
  next_stale_ = false;
  std::int64_t due = due_ns();
  // kLoop: the pass that takes the next frame when the bus frees is the one
  // at the end of the frame before, or the one that queued it: come back
  // when it ends.
  if (pacer_ == Pacer::kLoop && !busy_ && !queue_.empty())
    due = std::min(end_of(next_start(), queue_.top().bits), flight_due_ns());
  next_event_ = due == kNeverNs ? kNever : ceil_us(due);
}

}  // namespace cansim::io
