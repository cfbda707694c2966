#include "io/arbitration_queue.hpp"

#include <algorithm>

namespace cansim::io {

// Bits 30..20: the first 11 identifier bits; 19: RTR (11-bit) or SRR (29-bit,
// recessive); 18: IDE; 17..1: the 18 extension bits; 0: RTR (29-bit).
std::uint32_t ArbitrationQueue::key(const CanFrame& f) {
  const std::uint32_t rtr = f.rtr() ? 1 : 0;
  if (!f.extended()) return ((f.id & 0x7FF) << 20) | (rtr << 19);
  return (((f.id >> 18) & 0x7FF) << 20) | (3u << 18) | ((f.id & 0x3FFFF) << 1) | rtr;
}

ArbitrationQueue::ArbitrationQueue(std::size_t capacity) : pool_(std::max<std::size_t>(capacity, 1)), buckets_(kBuckets) {
  for (std::size_t i = pool_.size(); i-- > 0;) {
    pool_[i].next = free_;
    free_ = std::uint32_t(i);
  }
  extended_.reserve(pool_.size());
}

std::uint32_t ArbitrationQueue::take_free() {
  const std::uint32_t i = free_;
  free_ = pool_[i].next;
  pool_[i].next = kNone;
  pool_[i].queued = true;
  return i;
}

bool ArbitrationQueue::push(const QueuedFrame& q) {
  if (free_ == kNone) return false;
  const std::uint32_t i = take_free();
  pool_[i].q = q;
  ++size_;
  if (q.frame.extended()) {
    pool_[i].seq = seq_++;
    extended_.push_back(i);
    std::push_heap(extended_.begin(), extended_.end(), [this](std::uint32_t a, std::uint32_t b) { return extended_less(b, a); });
    return true;
  }
  const std::uint32_t b = key(q.frame) >> 19;
  Fifo& fifo = buckets_[b];
  if (fifo.tail == kNone) {
    fifo.head = i;
    words_[b / 64] |= std::uint64_t(1) << (b % 64);
    summary_ |= std::uint64_t(1) << (b / 64);
  } else {
    pool_[fifo.tail].next = i;
  }
  fifo.tail = i;
  return true;
}

bool ArbitrationQueue::extended_less(std::uint32_t a, std::uint32_t b) const {
  const std::uint32_t ka = key(pool_[a].q.frame), kb = key(pool_[b].q.frame);
  return ka != kb ? ka < kb : pool_[a].seq < pool_[b].seq;
}

bool ArbitrationQueue::standard_first() const {
  if (summary_ == 0) return false;
  if (extended_.empty()) return true;
  const unsigned w = unsigned(__builtin_ctzll(summary_));
  const std::uint32_t b = w * 64 + unsigned(__builtin_ctzll(words_[w]));
  return (b << 19) < key(pool_[extended_.front()].q.frame);
}

std::uint32_t ArbitrationQueue::top_index() const {
  if (!standard_first()) return extended_.front();
  const unsigned w = unsigned(__builtin_ctzll(summary_));
  return buckets_[w * 64 + unsigned(__builtin_ctzll(words_[w]))].head;
}

void ArbitrationQueue::pop() {
  if (standard_first()) pop_standard();
  else pop_extended();
  --size_;
}

void ArbitrationQueue::pop_standard() {
  const unsigned w = unsigned(__builtin_ctzll(summary_));
  const std::uint32_t b = w * 64 + unsigned(__builtin_ctzll(words_[w]));
  Fifo& fifo = buckets_[b];
  const std::uint32_t i = fifo.head;
  fifo.head = pool_[i].next;
  if (fifo.head == kNone) {
    fifo.tail = kNone;
    words_[w] &= ~(std::uint64_t(1) << (b % 64));
    if (words_[w] == 0) summary_ &= ~(std::uint64_t(1) << w);
  }
  pool_[i].queued = false;
  pool_[i].next = free_;
  free_ = i;
}

void ArbitrationQueue::pop_extended() {
  std::pop_heap(extended_.begin(), extended_.end(), [this](std::uint32_t a, std::uint32_t b) { return extended_less(b, a); });
  const std::uint32_t i = extended_.back();
  extended_.pop_back();
  pool_[i].queued = false;
  pool_[i].next = free_;
  free_ = i;
}

}  // namespace cansim::io
