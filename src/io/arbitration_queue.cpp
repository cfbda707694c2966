#include "io/arbitration_queue.hpp"

#include <algorithm>

namespace cansim::io {

ArbitrationQueue::ArbitrationQueue(std::size_t capacity)
    : pool_(std::max<std::size_t>(capacity, 1)), buckets_(kBuckets) {
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
  // Strictly lower: an equal key queued later stays behind.
  const std::uint32_t k = key(q.frame);
  if (size_++ == 0 || k < top_key_) {
    top_ = i;
    top_key_ = k;
  }
  if (q.frame.extended()) {
    pool_[i].seq = seq_++;
    extended_.push_back(i);
    std::push_heap(extended_.begin(), extended_.end(),
                   [this](std::uint32_t a, std::uint32_t b) { return extended_less(b, a); });
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

std::uint32_t ArbitrationQueue::find_top() const {
  if (summary_ == 0) return extended_.front();
  const unsigned w = unsigned(__builtin_ctzll(summary_));
  const std::uint32_t b = w * 64 + unsigned(__builtin_ctzll(words_[w]));
  if (!extended_.empty() && key(pool_[extended_.front()].q.frame) < (b << 19)) return extended_.front();
  return buckets_[b].head;
}

void ArbitrationQueue::pop() {
  if (pool_[top_].q.frame.extended()) pop_extended();
  else pop_standard();
  if (size_ == 0) return;
  top_ = find_top();
  top_key_ = key(pool_[top_].q.frame);
}

void ArbitrationQueue::release(std::uint32_t i) {
  pool_[i].queued = false;
  pool_[i].next = free_;
  free_ = i;
  --size_;
}

void ArbitrationQueue::unlink_bucket(std::uint32_t b) {
  buckets_[b].head = buckets_[b].tail = kNone;
  words_[b / 64] &= ~(std::uint64_t(1) << (b % 64));
  if (words_[b / 64] == 0) summary_ &= ~(std::uint64_t(1) << (b / 64));
}

void ArbitrationQueue::pop_standard() {
  const unsigned w = unsigned(__builtin_ctzll(summary_));
  const std::uint32_t b = w * 64 + unsigned(__builtin_ctzll(words_[w]));
  Fifo& fifo = buckets_[b];
  const std::uint32_t i = fifo.head;
  fifo.head = pool_[i].next;
  if (fifo.head == kNone) unlink_bucket(b);
  release(i);
}

void ArbitrationQueue::pop_extended() {
  std::pop_heap(extended_.begin(), extended_.end(),
                [this](std::uint32_t a, std::uint32_t b) { return extended_less(b, a); });
  const std::uint32_t i = extended_.back();
  extended_.pop_back();
  release(i);
}

}  // namespace cansim::io
