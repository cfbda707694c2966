// Deterministic randomness for the physics layer (written for this project).
//
//  * SplitMix64         - seed expander / 64-bit mixer.
//  * Xoshiro256ss       - fast sequential generator (xoshiro256** algorithm),
//                         seeded through SplitMix64.
//  * counter_hash()     - counter-based generator: a pure function of
//                         (key, counter). Used for per-sample noise so that a
//                         lazily evaluated sensor that "catches up" missed
//                         samples regenerates exactly the same values.
//  * normal_from_bits() - standard normal deviate from 64 bits (ziggurat).
//
// Seeds: derive_seed(fleet_seed, node_key) gives the node seed; derive_seed(node_seed,
// stream_tag) gives independent streams (process terms, channel noise, faults...).
#pragma once

#include <cmath>
#include <cstdint>
#include <string_view>

namespace cansim::physics {

// One SplitMix64 output step for state `x` (state advanced by the caller).
constexpr std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

class SplitMix64 {
 public:
  explicit constexpr SplitMix64(std::uint64_t seed) : state_(seed) {}
  constexpr std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ULL;
    return mix64(state_);
  }

 private:
  std::uint64_t state_;
};

// Counter-based 64-bit random value: pure function of (key, counter).
// Two mixing rounds so that neighbouring keys and counters decorrelate.
constexpr std::uint64_t counter_hash(std::uint64_t key, std::uint64_t counter) {
  return mix64(mix64(key ^ 0x6A09E667F3BCC909ULL) + counter * 0x9E3779B97F4A7C15ULL);
}

// Combine a seed with a stream tag / node key into an independent seed.
constexpr std::uint64_t derive_seed(std::uint64_t seed, std::uint64_t key) {
  return mix64(seed + 0x9E3779B97F4A7C15ULL * (mix64(key) | 1ULL));
}

// FNV-1a hash of a string, for textual node keys ("can0/12") and stream tags.
constexpr std::uint64_t hash_string(std::string_view s) {
  std::uint64_t h = 0xCBF29CE484222325ULL;
  for (char c : s) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001B3ULL;
  }
  return h;
}

// Uniform double in [0, 1) from the top 53 bits.
constexpr double uniform01(std::uint64_t bits) { return double(bits >> 11) * 0x1.0p-53; }

// The 128-layer ziggurat of the standard normal density (Marsaglia and Tsang,
// "The Ziggurat Method for Generating Random Variables", 2000): x[1] = r is
// where the tail starts, x[128] = 0; every layer has the same area.
struct ZigguratTables {
  static constexpr int kLayers = 128;
  double x[kLayers + 1];  // layer edges, x[0] = v / f(r) (the base layer and its tail)
  double ratio[kLayers];  // x[i + 1] / x[i]: |u| below it lies under the curve
};
const ZigguratTables& ziggurat_tables();

// The rare cases of normal_from_bits(): the edge of a layer and the tail.
double normal_from_bits_slow(std::uint64_t bits);

// No deviate of normal_from_bits() is larger in magnitude: a layer gives at
// most x[1] = r = 3.4426; the tail r + e1 / r with e1 = -log(u), u >= 2^-53,
// at most r + 53 ln 2 / r = 14.115.
inline constexpr double kNormalBound = 14.12;

// Standard normal deviate, a pure function of 64 random bits (ziggurat).
// 97.2 % of the draws take the first branch: no exp, log or trigonometry.
// The others draw again from bits that mix64 derives from these, so the
// result still depends on `bits` alone.
inline double normal_from_bits(std::uint64_t bits) {
  const ZigguratTables& z = ziggurat_tables();
  const unsigned layer = unsigned(bits & (ZigguratTables::kLayers - 1));
  const double u = double(std::int64_t(bits) >> 11) * 0x1.0p-52;  // [-1, 1) from the upper 53 bits
  if (std::abs(u) < z.ratio[layer]) return u * z.x[layer];
  return normal_from_bits_slow(bits);
}

// Standard normal deviate, pure function of (key, counter).
inline double counter_normal(std::uint64_t key, std::uint64_t counter) {
  return normal_from_bits(counter_hash(key, counter));
}

// xoshiro256** sequential generator.
class Xoshiro256ss {
 public:
  explicit constexpr Xoshiro256ss(std::uint64_t seed) : s_{} {
    SplitMix64 sm(seed);
    for (auto& w : s_) w = sm.next();
  }
  constexpr std::uint64_t next() {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  constexpr double uniform() { return uniform01(next()); }
  // Uniform in [lo, hi).
  constexpr double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  double normal() { return normal_from_bits(next()); }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4];
};

}  // namespace cansim::physics
