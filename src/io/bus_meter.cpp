#include "io/bus_meter.hpp"

#include <algorithm>

namespace cansim::io {

void BusMeter::reset(TimeUs now) {
  *this = BusMeter{};
  start_ = now;
  bin_ = now / kBin;
  slot_ = now / kDelaySlot;
}

void BusMeter::roll_to(std::int64_t bin) {
  // Bins skipped since the last frame carried nothing.
  for (std::int64_t b = bin_ + 1; b <= bin && b <= bin_ + std::int64_t(kBins); ++b) {
    offered_[b % kBins] = 0;
    carried_[b % kBins] = 0;
  }
  bin_ = bin;
}

void BusMeter::roll_delay(std::int64_t slot) {
  for (std::int64_t s = slot_ + 1; s <= slot && s <= slot_ + std::int64_t(kDelaySlots); ++s) {
    delays_[s % kDelaySlots].fill(0);
    delay_max_[s % kDelaySlots] = 0;
  }
  slot_ = slot;
}

std::size_t BusMeter::delay_bucket(TimeUs d) {
  if (d < 16) return d < 0 ? 0 : std::size_t(d);
  const int octave = 63 - __builtin_clzll(std::uint64_t(d));  // >= 4
  const std::size_t b = 16 + std::size_t(octave - 4) * 8 + std::size_t((d >> (octave - 3)) & 7);
  return std::min(b, kDelayBuckets - 1);
}

TimeUs BusMeter::bucket_upper(std::size_t bucket) {
  if (bucket < 16) return TimeUs(bucket);
  const int octave = int(bucket - 16) / 8 + 4;
  const TimeUs sub = TimeUs(bucket - 16) % 8;
  return ((8 + sub + 1) << (octave - 3)) - 1;
}

void BusMeter::delay(TimeUs d, TimeUs now) {
  if (now / kDelaySlot != slot_) roll_delay(now / kDelaySlot);
  const std::size_t s = std::size_t(slot_ % std::int64_t(kDelaySlots));
  ++delays_[s][delay_bucket(d)];
  delay_max_[s] = std::max(delay_max_[s], d);
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
  std::array<std::uint64_t, kDelayBuckets> sum{};
  const std::int64_t last = now / kDelaySlot;
  const std::int64_t oldest =
      std::max({last - std::int64_t(kDelaySlots) + 1, slot_ - std::int64_t(kDelaySlots) + 1, start_ / kDelaySlot});
  for (std::int64_t s = oldest; s <= std::min(last, slot_); ++s) {
    const std::size_t i = std::size_t(s % std::int64_t(kDelaySlots));
    for (std::size_t b = 0; b < kDelayBuckets; ++b) sum[b] += delays_[i][b];
    f.delay_max = std::max(f.delay_max, delay_max_[i]);
  }
  for (std::uint64_t n : sum) f.delayed += n;
  if (f.delayed == 0) return f;
  auto percentile = [&](std::uint64_t rank) {
    std::uint64_t seen = 0;
    for (std::size_t b = 0; b < kDelayBuckets; ++b)
      if ((seen += sum[b]) >= rank) return std::min(bucket_upper(b), f.delay_max);
    return f.delay_max;
  };
  // Nearest rank: the smallest delay at least p % of the frames did not exceed.
  f.delay_p50 = percentile((f.delayed * 50 + 99) / 100);
  f.delay_p99 = percentile((f.delayed * 99 + 99) / 100);
  return f;
}

}  // namespace cansim::io
