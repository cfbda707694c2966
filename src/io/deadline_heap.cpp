#include "io/deadline_heap.hpp"

namespace cansim::io {

void DeadlineHeap::reserve_slots(std::size_t n) {
  if (where_.size() >= n) return;
  where_.resize(n, kAbsent);
  key_.resize(n, kNever);
  seq_.resize(n, 0);
  heap_.reserve(n);
  std::size_t capacity = 16;
  while (capacity < 2 * n) capacity *= 2;
  if (capacity <= run_.size()) return;
  // Regrow the ring in order (node addition, not the hot path).
  std::vector<Entry> ring(capacity);
  for (std::size_t i = 0; i < run_size_; ++i) ring[i] = run_[(run_head_ + i) & (run_.size() - 1)];
  run_.swap(ring);
  run_head_ = 0;
}

void DeadlineHeap::set(std::uint32_t slot, TimeUs t) {
  const Entry e{t, slot, 0};
  if (t != kNever && append_to_run(e)) {  // takes the slot out of where it was
    drop_dead_front();
    return;
  }
  const std::uint32_t w = where_[slot];
  if (t != kNever && w != kAbsent && w != kInRun) {  // in the heap and staying there
    const TimeUs old = key_[slot];
    key_[slot] = t;
    if (t < old) sift_up(w, e);
    else if (t > old) sift_down(w, e);
    return;
  }
  remove(slot);
  if (t != kNever) {
    key_[slot] = t;
    heap_insert(e);
  }
  drop_dead_front();
}

bool DeadlineHeap::append_to_run(const Entry& e) {
  if (run_.empty()) return false;  // no reserve_slots() yet
  if (run_size_ > 0 && less(e, run_[(run_head_ + run_size_ - 1) & (run_.size() - 1)])) return false;
  if (run_size_ == run_.size()) compact_run();  // at most half the entries are live
  if (where_[e.slot] != kAbsent && where_[e.slot] != kInRun) heap_erase(where_[e.slot]);
  else if (where_[e.slot] == kInRun) --run_live_;
  Entry entry = e;
  entry.seq = ++next_seq_;
  seq_[e.slot] = entry.seq;
  where_[e.slot] = kInRun;
  key_[e.slot] = e.key;
  run_[(run_head_ + run_size_) & (run_.size() - 1)] = entry;
  ++run_size_;
  ++run_live_;
  return true;
}

void DeadlineHeap::remove(std::uint32_t slot) {
  const std::uint32_t w = where_[slot];
  if (w == kAbsent) return;
  if (w == kInRun) --run_live_;  // its entry is dead from now on
  else heap_erase(w);
  where_[slot] = kAbsent;
}

void DeadlineHeap::drop_dead_front() {
  while (run_size_ > 0 && !live(run_[run_head_])) {
    run_head_ = (run_head_ + 1) & (run_.size() - 1);
    --run_size_;
  }
}

void DeadlineHeap::compact_run() {
  std::size_t kept = 0;
  const std::size_t mask = run_.size() - 1;
  for (std::size_t i = 0; i < run_size_; ++i) {
    const Entry e = run_[(run_head_ + i) & mask];
    if (live(e)) run_[(run_head_ + kept++) & mask] = e;
  }
  run_size_ = kept;
}

void DeadlineHeap::heap_insert(const Entry& e) {
  heap_.push_back(e);  // capacity reserved by reserve_slots()
  sift_up(heap_.size() - 1, e);
}

void DeadlineHeap::heap_erase(std::uint32_t i) {
  where_[heap_[i].slot] = kAbsent;
  const Entry last = heap_.back();
  heap_.pop_back();
  if (i == heap_.size()) return;
  if (i > 0 && less(last, heap_[(i - 1) / kArity])) sift_up(i, last);
  else sift_down(i, last);
}

void DeadlineHeap::sift_up(std::size_t i, Entry e) {
  while (i > 0) {
    const std::size_t parent = (i - 1) / kArity;
    if (!less(e, heap_[parent])) break;
    heap_place(i, heap_[parent]);
    i = parent;
  }
  heap_place(i, e);
}

void DeadlineHeap::sift_down(std::size_t i, Entry e) {
  const std::size_t n = heap_.size();
  for (;;) {
    const std::size_t first = kArity * i + 1;
    if (first >= n) break;
    const std::size_t end = first + kArity < n ? first + kArity : n;
    std::size_t best = first;
    for (std::size_t c = first + 1; c < end; ++c) best = less(heap_[c], heap_[best]) ? c : best;
    if (!less(heap_[best], e)) break;
    heap_place(i, heap_[best]);
    i = best;
  }
  heap_place(i, e);
}

}  // namespace cansim::io
