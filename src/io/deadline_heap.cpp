#include "io/deadline_heap.hpp"

namespace cansim::io {

void DeadlineHeap::reserve_slots(std::size_t n) {
  if (pos_.size() >= n) return;
  pos_.resize(n, kAbsent);
  heap_.reserve(n);
}

void DeadlineHeap::set(std::uint32_t slot, TimeUs t) {
  if (t == kNever) {
    erase(slot);
    return;
  }
  const std::uint32_t i = pos_[slot];
  if (i == kAbsent) {
    heap_.push_back({t, slot});  // capacity reserved by reserve_slots()
    sift_up(heap_.size() - 1, {t, slot});
    return;
  }
  const TimeUs old = heap_[i].key;
  if (t < old) sift_up(i, {t, slot});
  else if (t > old) sift_down(i, {t, slot});
}

void DeadlineHeap::erase(std::uint32_t slot) {
  const std::uint32_t i = pos_[slot];
  if (i == kAbsent) return;
  pos_[slot] = kAbsent;
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
    place(i, heap_[parent]);
    i = parent;
  }
  place(i, e);
}

void DeadlineHeap::sift_down(std::size_t i, Entry e) {
  const std::size_t n = heap_.size();
  for (;;) {
    const std::size_t first = kArity * i + 1;
    if (first >= n) break;
    const std::size_t end = first + kArity < n ? first + kArity : n;
    std::size_t best = first;
    for (std::size_t c = first + 1; c < end; ++c)
      if (less(heap_[c], heap_[best])) best = c;
    if (!less(heap_[best], e)) break;
    place(i, heap_[best]);
    i = best;
  }
  place(i, e);
}

}  // namespace cansim::io
