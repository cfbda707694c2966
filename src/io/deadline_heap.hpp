// The node deadlines of a loop: one key per node slot, the earliest first,
// ties broken by slot number (which keeps runs deterministic). Updated after
// every on_frame / advance, so a wake-up never scans the fleet.
//
// Two sorted stores, the earlier front wins:
//  * a run: a ring of deadlines in ascending order. A node whose new deadline
//    is not earlier than the run's last is appended in O(1). In a fleet most
//    are: nodes due at the same instant run in slot order and get the same
//    next deadline, so the run simply rotates. An entry replaced later stays
//    in the ring as a dead entry (its sequence number no longer matches) and
//    is dropped when it reaches the front or when the ring is compacted.
//  * a 4-ary min-heap with inline keys for the rest, O(log n).
// A binary heap alone cost about 80 ns per wake-up (12 % of a fleet's CPU):
// the node that ran sank through every level, the deadlines being all equal.
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
  // Sets the deadline of a slot; kNever takes it out.
  void set(std::uint32_t slot, TimeUs t);
  bool empty() const { return size() == 0; }
  std::uint32_t top() const { return run_first() ? run_[run_head_].slot : heap_.front().slot; }
  TimeUs top_time() const {
    if (run_first()) return run_[run_head_].key;
    return heap_.empty() ? kNever : heap_.front().key;
  }
  TimeUs deadline(std::uint32_t slot) const { return where_[slot] == kAbsent ? kNever : key_[slot]; }
  std::size_t size() const { return heap_.size() + run_live_; }

 private:
  static constexpr std::size_t kArity = 4;
  static constexpr std::uint32_t kInRun = 0xFFFFFFFEu;  // where_: in the run, else heap index
  struct alignas(16) Entry {
    TimeUs key;
    std::uint32_t slot;
    std::uint32_t seq;  // run entries: live while it equals seq_[slot]
  };
  // Bitwise, not short-circuit: the compiler can select without branching
  // (equal deadlines are the rule in a fleet, so the branches mispredict).
  static bool less(const Entry& a, const Entry& b) { return (a.key < b.key) | ((a.key == b.key) & (a.slot < b.slot)); }
  bool run_first() const { return run_size_ > 0 && (heap_.empty() || less(run_[run_head_], heap_.front())); }
  // The key as well: a 32-bit sequence number wraps after ~10 h of a busy fleet.
  bool live(const Entry& e) const { return where_[e.slot] == kInRun && seq_[e.slot] == e.seq && key_[e.slot] == e.key; }

  void remove(std::uint32_t slot);
  bool append_to_run(const Entry& e);
  void drop_dead_front();
  void compact_run();
  void heap_place(std::size_t i, const Entry& e) {
    heap_[i] = e;
    where_[e.slot] = std::uint32_t(i);
  }
  void heap_insert(const Entry& e);
  void heap_erase(std::uint32_t i);
  void sift_up(std::size_t i, Entry e);
  void sift_down(std::size_t i, Entry e);

  std::vector<TimeUs> key_;           // slot -> deadline, valid unless where_ is kAbsent
  std::vector<std::uint32_t> where_;  // slot -> heap index, kInRun or kAbsent
  std::vector<std::uint32_t> seq_;    // slot -> sequence number of its live run entry
  std::vector<Entry> heap_;           // heap-ordered; the children of i are kArity * i + 1 ...
  std::vector<Entry> run_;            // ring, capacity a power of two >= 2 x slots
  std::size_t run_head_ = 0, run_size_ = 0, run_live_ = 0;
  std::uint32_t next_seq_ = 0;
};

}  // namespace cansim::io
