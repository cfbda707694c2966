// What one bus carried, for the control API: the bits offered (frames local
// nodes wanted to send, dropped ones included, and frames from the wire) and
// carried (frames that went on the wire) in 100 ms bins over the last 10 s;
// the queueing delay of each frame (queued -> start of transmission) and the
// slip of the bus (how much later than its schedule a frame left, when the
// loop woke late) in one histogram per second over the last 10 s. O(1) per
// frame, no allocation.
//
// Loads are over the last complete 1 s and 10 s: the 10 and 100 bins before
// the one `now` is in (the figures move every 100 ms), shortened to the time
// since the meter started. Carried never exceeds the bit rate by more than a
// bin's rounding (a frame counts in the bin it ended in): the bus's owner
// counts only the wire time a frame added. Delays are over the current
// second and the 9 before, kept in buckets 1/8 octave wide (exact below
// 16 µs): a percentile is its bucket's upper bound (at most 12.5 % high),
// never above the max.
#pragma once

#include <array>
#include <cstdint>

#include "core/can_frame.hpp"

namespace cansim::io {

// Durations (µs) over the current second and the 9 before.
class WindowHistogram {
 public:
  static constexpr TimeUs kSlot = 1'000'000;
  static constexpr std::size_t kSlots = 10;
  static constexpr std::size_t kBuckets = 16 + 8 * 40;

  struct Figures {
    TimeUs p50 = 0, p99 = 0, max = 0;
    std::uint64_t count = 0;
  };

  void reset(TimeUs now);
  void add(TimeUs d, TimeUs now);
  Figures figures(TimeUs now) const;

  static std::size_t bucket(TimeUs d);
  static TimeUs bucket_upper(std::size_t bucket);

 private:
  void roll(std::int64_t slot);

  TimeUs start_ = 0;
  std::int64_t slot_ = 0;
  std::array<std::array<std::uint32_t, kBuckets>, kSlots> counts_{};
  std::array<TimeUs, kSlots> max_{};
};

class BusMeter {
 public:
  static constexpr TimeUs kBin = 100'000;    // load bins: 100 ms
  static constexpr std::size_t kBins = 101;  // 10 s + the current bin

  struct Figures {
    double offered_1s = 0, offered_10s = 0;  // bits per second
    double carried_1s = 0, carried_10s = 0;
    TimeUs delay_p50 = 0, delay_p99 = 0, delay_max = 0;  // µs, over 10 s
    std::uint64_t delayed = 0;                           // frames the delay figures count
    TimeUs slip_p99 = 0, slip_max = 0;                   // µs, over 10 s, of every frame carried
  };

  // Forgets everything; windows start at `now`.
  void reset(TimeUs now);
  void offered(int bits, TimeUs now) {
    roll(now);
    offered_[bin_ % kBins] += std::uint32_t(bits);
  }
  void carried(int bits, TimeUs now) {
    roll(now);
    carried_[bin_ % kBins] += std::uint32_t(bits);
  }
  // A frame on the wire the instant it was offered (ideal bus, outside frames).
  void offered_and_carried(int bits, TimeUs now) {
    roll(now);
    offered_[bin_ % kBins] += std::uint32_t(bits);
    carried_[bin_ % kBins] += std::uint32_t(bits);
  }
  void delay(TimeUs d, TimeUs now) { delays_.add(d, now); }
  // Every frame a timed bus carried: how late it left (0: on schedule).
  void slip(TimeUs d, TimeUs now) { slips_.add(d, now); }
  Figures figures(TimeUs now) const;

 private:
  void roll(TimeUs now) {
    if (now / kBin != bin_) roll_to(now / kBin);
  }
  void roll_to(std::int64_t bin);
  double bits_per_s(const std::array<std::uint32_t, kBins>& bins, TimeUs window, TimeUs now) const;

  TimeUs start_ = 0;
  std::int64_t bin_ = 0;
  std::array<std::uint32_t, kBins> offered_{};
  std::array<std::uint32_t, kBins> carried_{};
  WindowHistogram delays_;
  WindowHistogram slips_;
};

}  // namespace cansim::io
