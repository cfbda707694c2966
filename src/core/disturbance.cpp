#include "core/disturbance.hpp"

#include <algorithm>
#include <cmath>

namespace cansim {

namespace {
constexpr std::int64_t kNeverNs = std::numeric_limits<std::int64_t>::max();
}

bool Disturbance::running(std::uint32_t id) const {
  return std::any_of(sources_.begin(), sources_.begin() + std::ptrdiff_t(n_),
                     [&](const Source& s) { return s.id == id; });
}

void Disturbance::babble(std::uint32_t id, const CanFrame& frame, double rate_hz, TimeUs now) {
  if (running(id) || n_ == kMax || !(rate_hz > 0)) return;
  Source& s = sources_[n_++];
  s = Source{};
  s.id = id;
  s.babbling = true;
  s.frame = frame;
  s.period_ns = std::max<std::int64_t>(1, std::llround(1e9 / rate_hz));
  s.next_ns = now * 1000;
}

void Disturbance::error_frames(std::uint32_t id, BusError error, TimeUs period, TimeUs now) {
  if (running(id) || n_ == kMax) return;
  Source& s = sources_[n_++];
  s = Source{};
  s.id = id;
  s.error = error;
  s.period_ns = period > 0 ? period * 1000 : 0;
  s.next_ns = now * 1000;
}

TimeUs Disturbance::earliest() const {
  std::int64_t next = kNeverNs;
  for (std::size_t i = 0; i < n_; ++i) next = std::min(next, sources_[i].next_ns);
  return next == kNeverNs ? kNever : (next + 999) / 1000;
}

BusError Disturbance::way_back(BusError e) {
  switch (e) {
    case BusError::kWarning:
    case BusError::kPassive: return BusError::kActive;
    case BusError::kBusOff: return BusError::kRestarted;
    default: return e;
  }
}

}  // namespace cansim
