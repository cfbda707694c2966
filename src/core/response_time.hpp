// A response time of a node (docs/faults.md "Response times"): how long the
// device takes to answer (SDO turnaround, synchronous TPDOs after SYNC, the
// boot-up after a reset), a fixed part plus a uniform jitter 0..jitter.
//
// The jitter of the n-th draw since a power-on is a pure function of the
// node's seed (fleet seed, node key and the power-on's number: Node::seed),
// the service's stream and n, so a run with the same seed and the same
// traffic draws the same times; the state is the seed and one counter (a
// value: copies with the node's snapshot). No jitter: no draw.
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
  // The next response's time: fixed + 0..jitter (inclusive). A new
  // node_seed (the node's next power-on) starts the count again.
  TimeUs next(std::uint64_t node_seed) {
    if (jitter_ == 0) return fixed_;
    if (node_seed != seed_) {
      seed_ = node_seed;
      draws_ = 0;
    }
    FaultRandom draw(mix_seed(mix_seed(node_seed ^ stream_, 0), draws_++));
    return fixed_ + draw.upto(jitter_);
  }

 private:
  std::uint64_t stream_;
  TimeUs fixed_ = 0, jitter_ = 0;
  std::uint64_t seed_ = 0, draws_ = 0;
};

}  // namespace cansim
