#include "io/timed_bus.hpp"

#include <algorithm>

namespace cansim::io {

namespace {
TimeUs ceil_us(std::int64_t ns) { return (ns + 999) / 1000; }
}  // namespace

bool TimedBus::submit(const QueuedFrame& q, TimeUs) {
  if (queue_.push(q)) return true;
  ++dropped_;
  return false;
}

void TimedBus::occupy(int bits, TimeUs now) {
  const std::int64_t from = busy_ ? free_ns_ : std::max(free_ns_, now * 1000);
  free_ns_ = from + bits * bit_ns_;
}

bool TimedBus::settle(TimeUs now, Phase phase, QueuedFrame& done, std::int64_t& started_ns) {
  const std::int64_t now_ns = now * 1000;
  for (;;) {
    if (busy_) {
      if (end_ns_ > now_ns) return false;
      busy_ = false;
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
  }
}

TimeUs TimedBus::next_event() const {
  if (busy_) return ceil_us(end_ns_);
  if (queue_.empty()) return kNever;
  const QueuedFrame& next = queue_.top();
  return ceil_us(end_of(std::max(free_ns_, next.queued_at * 1000), next.bits));
}

}  // namespace cansim::io
