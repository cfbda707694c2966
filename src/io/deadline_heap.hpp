// Indexed binary min-heap of node deadlines: one key per node slot, updated
// in O(log n) after every on_frame / advance, so a wake-up never scans the
// fleet. Ties are broken by slot number, which keeps runs deterministic.
#pragma once

#include <cstdint>
#include <vector>

#include "core/can_frame.hpp"

namespace cansim::io {

class DeadlineHeap {
 public:
  static constexpr std::uint32_t kAbsent = 0xFFFFFFFFu;

  // Makes room for slots [0, n). Allocates; call when nodes are added.
  void reserve_slots(std::size_t n);
  // Sets the deadline of a slot; kNever takes it out of the heap.
  void set(std::uint32_t slot, TimeUs t);
  bool empty() const { return heap_.empty(); }
  std::uint32_t top() const { return heap_.front(); }
  TimeUs top_time() const { return heap_.empty() ? kNever : key_[heap_.front()]; }
  TimeUs deadline(std::uint32_t slot) const { return pos_[slot] == kAbsent ? kNever : key_[slot]; }
  std::size_t size() const { return heap_.size(); }

 private:
  bool less(std::uint32_t a, std::uint32_t b) const {
    return key_[a] < key_[b] || (key_[a] == key_[b] && a < b);
  }
  void place(std::size_t i, std::uint32_t slot) {
    heap_[i] = slot;
    pos_[slot] = std::uint32_t(i);
  }
  void sift_up(std::size_t i);
  void sift_down(std::size_t i);
  void erase(std::uint32_t slot);

  std::vector<std::uint32_t> heap_;  // slots, heap-ordered
  std::vector<std::uint32_t> pos_;   // slot -> index in heap_, or kAbsent
  std::vector<TimeUs> key_;          // slot -> deadline
};

}  // namespace cansim::io
