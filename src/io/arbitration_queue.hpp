// The frames waiting for a timed bus, in the order CAN arbitration takes
// them (ISO 11898-1 §10.8): the identifier bits MSB first, a dominant bit (0)
// winning. Between an 11-bit and a 29-bit frame with the same first 11 bits,
// the 11-bit data frame wins at RTR vs SRR and the 11-bit remote frame at IDE;
// a data frame beats a remote frame of its identifier. Frames with the same
// identifier (one node's SDO segments; two nodes misconfigured onto one
// COB-ID) leave in the order they were queued.
//
// Bounded, allocated once: push, top and pop are O(1) for 11-bit frames (a
// FIFO per identifier and RTR bit, found through a two-level bitmap); 29-bit
// frames, rare in CANopen, sit in a small binary heap beside it.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/can_frame.hpp"

namespace cansim::io {

struct QueuedFrame {
  CanFrame frame;
  TimeUs queued_at = 0;         // when its node sent it
  std::uint32_t from = 0;       // the sender's NodeRef
  std::uint16_t bits = 0;       // wire_bits(frame)
  std::uint8_t controller = 0;  // FrameSink::kOwn, or the node's twin
  std::uint64_t order = 0;      // TimedBus: frames it took before this one
};

class ArbitrationQueue {
 public:
  explicit ArbitrationQueue(std::size_t capacity = 1024);

  // The arbitration field as one number, the lower wins. Bits 30..20: the
  // first 11 identifier bits; 19: RTR (11-bit) or SRR (29-bit, recessive);
  // 18: IDE; 17..1: the 18 extension bits; 0: RTR (29-bit).
  static std::uint32_t key(const CanFrame& f) {
    const std::uint32_t rtr = f.rtr() ? 1 : 0;
    if (!f.extended()) return ((f.id & 0x7FF) << 20) | (rtr << 19);
    return (((f.id >> 18) & 0x7FF) << 20) | (3u << 18) | ((f.id & 0x3FFFF) << 1) | rtr;
  }

  // False when full (the caller counts the drop).
  bool push(const QueuedFrame& q);
  bool empty() const { return size_ == 0; }
  std::size_t size() const { return size_; }
  std::size_t capacity() const { return pool_.size(); }
  // The frame that wins arbitration now. Only when !empty().
  const QueuedFrame& top() const { return pool_[top_].q; }
  void pop();
  // Takes out every frame for which pred(const QueuedFrame&) is true (the
  // others keep their order); returns how many. O(size + buckets in use).
  template <typename Pred>
  std::size_t remove_if(Pred&& pred);
  // Calls fn(QueuedFrame&) for every queued frame (any order).
  template <typename Fn>
  void for_each(Fn&& fn) {
    for (Entry& e : pool_)
      if (e.queued) fn(e.q);
  }
  template <typename Fn>
  void for_each(Fn&& fn) const {
    for (const Entry& e : pool_)
      if (e.queued) fn(e.q);
  }

 private:
  static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  static constexpr std::size_t kBuckets = 4096;  // 11-bit identifier << 1 | RTR
  struct Entry {
    QueuedFrame q;
    std::uint32_t next = kNone;  // FIFO of its bucket, or the free list
    std::uint64_t seq = 0;       // 29-bit heap: queue order among equal keys
    bool queued = false;
  };
  struct Fifo {
    std::uint32_t head = kNone, tail = kNone;
  };

  std::uint32_t find_top() const;
  std::uint32_t take_free();
  void release(std::uint32_t i);
  void unlink_bucket(std::uint32_t b);
  void pop_standard();
  void pop_extended();
  bool extended_less(std::uint32_t a, std::uint32_t b) const;

  std::vector<Entry> pool_;
  std::uint32_t free_ = kNone;
  std::size_t size_ = 0;
  std::uint32_t top_ = kNone;  // the winner, kept by push and pop
  std::uint32_t top_key_ = 0;
  std::vector<Fifo> buckets_;
  std::uint64_t summary_ = 0;                // bit w: words_[w] != 0
  std::uint64_t words_[kBuckets / 64] = {};  // bit b of word w: bucket 64 w + b not empty
  std::vector<std::uint32_t> extended_;      // binary heap of pool indices
  std::uint64_t seq_ = 0;
};

template <typename Pred>
std::size_t ArbitrationQueue::remove_if(Pred&& pred) {
  const std::size_t before = size_;
  for (std::size_t w = 0; w < kBuckets / 64; ++w)
    for (std::uint64_t bits = words_[w]; bits; bits &= bits - 1) {
      const auto b = std::uint32_t(w * 64 + unsigned(__builtin_ctzll(bits)));
      std::uint32_t kept_tail = kNone;
      for (std::uint32_t i = buckets_[b].head, next; i != kNone; i = next) {
        next = pool_[i].next;
        if (pred(static_cast<const QueuedFrame&>(pool_[i].q))) {
          release(i);
          continue;
        }
        if (kept_tail == kNone) buckets_[b].head = i;
        else pool_[kept_tail].next = i;
        pool_[i].next = kNone;
        kept_tail = i;
      }
      buckets_[b].tail = kept_tail;
      if (kept_tail == kNone) unlink_bucket(b);
    }
  std::erase_if(extended_, [&](std::uint32_t i) {
    if (!pred(static_cast<const QueuedFrame&>(pool_[i].q))) return false;
    release(i);
    return true;
  });
  std::make_heap(extended_.begin(), extended_.end(),
                 [this](std::uint32_t a, std::uint32_t b) { return extended_less(b, a); });
  if (size_ > 0) {
    top_ = find_top();
    top_key_ = key(pool_[top_].q.frame);
  }
  return before - size_;
}

}  // namespace cansim::io
