#include "io/timed_bus.hpp"

#include <algorithm>

namespace cansim::io {

namespace {
TimeUs ceil_us(std::int64_t ns) { return (ns + 999) / 1000; }
}  // namespace

bool TimedBus::submit(QueuedFrame q, TimeUs) {
  q.order = taken_;
  if (!queue_.push(q)) {
    ++dropped_;
    return false;
  }
  ++taken_;
  next_stale_ |= !busy_;
  return true;
}

bool TimedBus::holds_before(std::uint64_t mark) const {
  bool holds = busy_ && current_.order < mark;
  queue_.for_each([&](const QueuedFrame& q) { holds |= q.order < mark; });
  return holds;
}

void TimedBus::occupy(int bits, TimeUs now) {
  const std::int64_t from = busy_ ? free_ns_ : std::max(free_ns_, now * 1000);
  free_ns_ = from + bits * bit_ns_;
  next_stale_ |= !busy_;
}

bool TimedBus::settle(TimeUs now, Phase phase, QueuedFrame& done, std::int64_t& started_ns) {
  const std::int64_t now_ns = now * 1000;
  for (;;) {
    if (busy_) {
      if (end_ns_ > now_ns) return false;
      busy_ = false;
      next_stale_ = true;
      done = current_;
      started_ns = start_ns_;
      return true;
    }
    if (queue_.empty()) return false;
    // Arbitration when the bus is free: before `now` only among the frames
    // queued earlier (every frame queued then was there by free_ns_), at
    // `now` among those queued at `now` too.
    if (phase == Phase::kBefore ? free_ns_ >= now_ns : free_ns_ > now_ns) return false;
    current_ = queue_.top();
    queue_.pop();
    busy_ = true;
    start_ns_ = std::max(free_ns_, current_.queued_at * 1000);
    end_ns_ = end_of(start_ns_, current_.bits);
    free_ns_ = start_ns_ + current_.bits * bit_ns_;
    next_event_ = ceil_us(end_ns_);
    next_stale_ = false;
  }
}

void TimedBus::refresh_next_event() const {
  next_stale_ = false;
  if (busy_) {
    next_event_ = ceil_us(end_ns_);
  } else if (queue_.empty()) {
    next_event_ = kNever;
  } else {
    const QueuedFrame& next = queue_.top();
    next_event_ = ceil_us(end_of(std::max(free_ns_, next.queued_at * 1000), next.bits));
  }
}

}  // namespace cansim::io
