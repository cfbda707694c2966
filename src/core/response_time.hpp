// A response time of a node (docs/faults.md "Response times"): how long the
// device takes to answer (SDO turnaround, synchronous TPDOs after SYNC, the
// boot-up after a reset), a fixed part plus a uniform jitter 0..jitter.
//
// The jitter of the n-th draw is a pure function of the node's seed (fleet
// seed and node key, NodeSetup::seed), the service's stream and n, so a run
// with the same seed and the same traffic draws the same times; the state is
// one counter (a value: copies with the node's snapshot). No jitter: no draw.
#pragma once

#include <cstdint>

#include "core/can_frame.hpp"
#include "core/fault_random.hpp"

namespace cansim {

class ResponseTime {
 public:
  // The services' streams: one generator each, independent of the others.
  enum class Stream : std::uint64_t { kSdoTurnaround = 0x5D0, kSyncTpdo = 0x5C0, kBootUp = 0xB00 };

  explicit ResponseTime(Stream stream) : stream_(std::uint64_t(stream)) {}
  void set(TimeUs fixed, TimeUs jitter) {
    fixed_ = fixed > 0 ? fixed : 0;
    jitter_ = jitter > 0 ? jitter : 0;
  }
  bool any() const { return fixed_ > 0 || jitter_ > 0; }
  // The next response's time: fixed + 0..jitter (inclusive).
  TimeUs next(std::uint64_t node_seed) {
    if (jitter_ == 0) return fixed_;
    FaultRandom draw(mix(mix(node_seed ^ stream_) + draws_++));
    return fixed_ + draw.upto(jitter_);
  }

 private:
  // SplitMix64's finaliser: neighbouring seeds and counters decorrelate.
  static std::uint64_t mix(std::uint64_t z) {
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }

  std::uint64_t stream_;
  TimeUs fixed_ = 0, jitter_ = 0;
  std::uint64_t draws_ = 0;
};

}  // namespace cansim
