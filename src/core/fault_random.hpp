// The randomness of the network faults (which frames a fault hits, by how
// much): one small generator per fault, seeded from the fleet seed and the
// fault's handle (physics::FaultSet::seed), so a run reproduces bit for bit.
// Each power-on of a node starts its streams afresh from (seed, the number
// of that power-on): what follows a power cycle does not depend on how many
// frames went before it, only on how many power cycles did.
#pragma once

#include <cstdint>

namespace cansim {

// SplitMix64's finaliser over seed + key: neighbouring keys decorrelate
// (physics::mix64 is the same function; core may not include physics).
constexpr std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t key) {
  std::uint64_t z = seed + key + 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// xorshift64* (Vigna): 64 bits of state, one multiply per draw.
class FaultRandom {
 public:
  explicit FaultRandom(std::uint64_t seed = 1) : s_(seed ? seed : 0x9E3779B97F4A7C15ull) {}
  std::uint64_t next() {
    s_ ^= s_ >> 12;
    s_ ^= s_ << 25;
    s_ ^= s_ >> 27;
    return s_ * 0x2545F4914F6CDD1Dull;
  }
  // True with probability p (0..1).
  bool chance(double p) { return p >= 1.0 || double(next() >> 11) * 0x1.0p-53 < p; }
  // 0..n inclusive.
  std::int64_t upto(std::int64_t n) { return n <= 0 ? 0 : std::int64_t(next() % std::uint64_t(n + 1)); }

 private:
  std::uint64_t s_;
};

}  // namespace cansim
