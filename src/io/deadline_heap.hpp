// Indexed 4-ary min-heap of node deadlines: one key per node slot, updated
// in O(log n) after every on_frame / advance, so a wake-up never scans the
// fleet. Ties are broken by slot number, which keeps runs deterministic.
// Each entry carries its key, so a sift compares without chasing slot -> key,
// and four children per node halve the depth of a binary heap (the sift after
// a wake-up was 13 % of a fleet's CPU with a binary heap of slot numbers).
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
  std::uint32_t top() const { return heap_.front().slot; }
  TimeUs top_time() const { return heap_.empty() ? kNever : heap_.front().key; }
  TimeUs deadline(std::uint32_t slot) const { return pos_[slot] == kAbsent ? kNever : heap_[pos_[slot]].key; }
  std::size_t size() const { return heap_.size(); }

 private:
  static constexpr std::size_t kArity = 4;
  struct alignas(16) Entry {
    TimeUs key;
    std::uint32_t slot;
  };
  static bool less(const Entry& a, const Entry& b) { return a.key < b.key || (a.key == b.key && a.slot < b.slot); }
  void place(std::size_t i, const Entry& e) {
    heap_[i] = e;
    pos_[e.slot] = std::uint32_t(i);
  }
  void sift_up(std::size_t i, Entry e);
  void sift_down(std::size_t i, Entry e);
  void erase(std::uint32_t slot);

  // The children of i are kArity * i + 1 ... kArity * i + kArity.
  std::vector<Entry> heap_;          // heap-ordered
  std::vector<std::uint32_t> pos_;   // slot -> index in heap_, or kAbsent
};

}  // namespace cansim::io
