#include "io/deadline_heap.hpp"

namespace cansim::io {

void DeadlineHeap::reserve_slots(std::size_t n) {
  if (pos_.size() >= n) return;
  pos_.resize(n, kAbsent);
  key_.resize(n, kNever);
  heap_.reserve(n);
}

void DeadlineHeap::set(std::uint32_t slot, TimeUs t) {
  if (t == kNever) {
    erase(slot);
    return;
  }
  std::uint32_t i = pos_[slot];
  if (i == kAbsent) {
    key_[slot] = t;
    heap_.push_back(slot);  // capacity reserved by reserve_slots()
    pos_[slot] = std::uint32_t(heap_.size() - 1);
    sift_up(heap_.size() - 1);
    return;
  }
  TimeUs old = key_[slot];
  key_[slot] = t;
  if (t < old) sift_up(i);
  else if (t > old) sift_down(i);
}

void DeadlineHeap::erase(std::uint32_t slot) {
  std::uint32_t i = pos_[slot];
  if (i == kAbsent) return;
  pos_[slot] = kAbsent;
  std::uint32_t last = heap_.back();
  heap_.pop_back();
  if (i == heap_.size()) return;
  place(i, last);
  sift_up(i);
  sift_down(pos_[last]);
}

void DeadlineHeap::sift_up(std::size_t i) {
  std::uint32_t slot = heap_[i];
  while (i > 0) {
    std::size_t parent = (i - 1) / 2;
    if (!less(slot, heap_[parent])) break;
    place(i, heap_[parent]);
    i = parent;
  }
  place(i, slot);
}

void DeadlineHeap::sift_down(std::size_t i) {
  std::uint32_t slot = heap_[i];
  const std::size_t n = heap_.size();
  for (;;) {
    std::size_t child = 2 * i + 1;
    if (child >= n) break;
    if (child + 1 < n && less(heap_[child + 1], heap_[child])) ++child;
    if (!less(heap_[child], slot)) break;
    place(i, heap_[child]);
    i = child;
  }
  place(i, slot);
}

}  // namespace cansim::io
