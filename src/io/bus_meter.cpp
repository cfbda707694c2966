#include "io/bus_meter.hpp"

#include <algorithm>

namespace cansim::io {

// ---------------------------------------------------------------- WindowHistogram

void WindowHistogram::reset(TimeUs now) {
  *this = WindowHistogram{};
  start_ = now;
  slot_ = now / kSlot;
}

void WindowHistogram::roll(std::int64_t slot) {
  for (std::int64_t s = slot_ + 1; s <= slot && s <= slot_ + std::int64_t(kSlots); ++s) {
    counts_[s % kSlots].fill(0);
    max_[s % kSlots] = 0;
  }
  slot_ = slot;
}

std::size_t WindowHistogram::bucket(TimeUs d) {
  if (d < 16) return d < 0 ? 0 : std::size_t(d);
  const int octave = 63 - __builtin_clzll(std::uint64_t(d));  // >= 4
  const std::size_t b = 16 + std::size_t(octave - 4) * 8 + std::size_t((d >> (octave - 3)) & 7);
  return std::min(b, kBuckets - 1);
}

TimeUs WindowHistogram::bucket_upper(std::size_t bucket) {
  if (bucket < 16) return TimeUs(bucket);
  const int octave = int(bucket - 16) / 8 + 4;
  const TimeUs sub = TimeUs(bucket - 16) % 8;
  return ((8 + sub + 1) << (octave - 3)) - 1;
}

void WindowHistogram::add(TimeUs d, TimeUs now) {
  if (now / kSlot != slot_) roll(now / kSlot);
  const std::size_t s = std::size_t(slot_ % std::int64_t(kSlots));
  ++counts_[s][bucket(d)];
  max_[s] = std::max(max_[s], d);
}

WindowHistogram::Figures WindowHistogram::figures(TimeUs now) const {
  Figures f;
  std::array<std::uint64_t, kBuckets> sum{};
  const std::int64_t last = now / kSlot;
  const std::int64_t oldest =
      std::max({last - std::int64_t(kSlots) + 1, slot_ - std::int64_t(kSlots) + 1, start_ / kSlot});
  for (std::int64_t s = oldest; s <= std::min(last, slot_); ++s) {
    const std::size_t i = std::size_t(s % std::int64_t(kSlots));
    for (std::size_t b = 0; b < kBuckets; ++b) sum[b] += counts_[i][b];
    f.max = std::max(f.max, max_[i]);
  }
  for (std::uint64_t n : sum) f.count += n;
  if (f.count == 0) return f;
  auto percentile = [&](std::uint64_t rank) {
    std::uint64_t seen = 0;
    for (std::size_t b = 0; b < kBuckets; ++b)
      if ((seen += sum[b]) >= rank) return std::min(bucket_upper(b), f.max);
    return f.max;
  };
  // Nearest rank: the smallest value at least p % of the samples did not exceed.
  f.p50 = percentile((f.count * 50 + 99) / 100);
  f.p99 = percentile((f.count * 99 + 99) / 100);
  return f;
}

// ---------------------------------------------------------------- BusMeter

void BusMeter::reset(TimeUs now) {
  *this = BusMeter{};
  start_ = now;
  bin_ = now / kBin;
  delays_.reset(now);
  slips_.reset(now);
}

void BusMeter::roll_to(std::int64_t bin) {
  // Bins skipped since the last frame carried nothing.
  for (std::int64_t b = bin_ + 1; b <= bin && b <= bin_ + std::int64_t(kBins); ++b) {
    offered_[b % kBins] = 0;
    carried_[b % kBins] = 0;
  }
  bin_ = bin;
}

double BusMeter::bits_per_s(const std::array<std::uint32_t, kBins>& bins, TimeUs window, TimeUs now) const {
  // The complete bins of the window: [last - n, last), `last` the bin now is in.
  const std::int64_t last = now / kBin;
  const std::int64_t first = last - window / kBin;
  const TimeUs from = std::max(first * kBin, start_), to = last * kBin;
  if (to <= from) return 0;
  std::uint64_t bits = 0;
  // Bins the meter has not reached yet, or left behind, hold nothing for `now`.
  const std::int64_t oldest = std::max({first, bin_ - std::int64_t(kBins) + 1, start_ / kBin});
  for (std::int64_t b = oldest; b < std::min(last, bin_ + 1); ++b) bits += bins[b % kBins];
  return double(bits) * 1e6 / double(to - from);
}

BusMeter::Figures BusMeter::figures(TimeUs now) const {
  Figures f;
  f.offered_1s = bits_per_s(offered_, 1'000'000, now);
  f.offered_10s = bits_per_s(offered_, 10'000'000, now);
  f.carried_1s = bits_per_s(carried_, 1'000'000, now);
  f.carried_10s = bits_per_s(carried_, 10'000'000, now);
  const WindowHistogram::Figures d = delays_.figures(now);
  f.delay_p50 = d.p50;
  f.delay_p99 = d.p99;
  f.delay_max = d.max;
  f.delayed = d.count;
  const WindowHistogram::Figures s = slips_.figures(now);
  f.slip_p99 = s.p99;
  f.slip_max = s.max;
  return f;
}

}  // namespace cansim::io
