// Frames an outside participant hands the daemon ahead of their time
// (cansimctl replay, through Fleet1.QueueFrames: docs/socketcand.md "Record
// and replay"), each to be submitted to its bus (LoopCore::submit) when its
// time comes: a bounded binary min-heap by time, then order of arrival,
// allocated once. The owner arms the loop's timer at next() and calls
// release() at each pass.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/can_frame.hpp"

namespace cansim::io {

class FrameSchedule {
 public:
  explicit FrameSchedule(std::size_t capacity) : capacity_(capacity) { heap_.reserve(capacity); }

  std::size_t size() const { return heap_.size(); }
  std::size_t room() const { return capacity_ - heap_.size(); }
  // False when full.
  bool push(TimeUs at, const CanFrame& frame) {
    if (heap_.size() == capacity_) return false;
    heap_.push_back({at, seq_++, frame});
    std::push_heap(heap_.begin(), heap_.end(), later);
    return true;
  }
  // The earliest frame's time, kNever when empty.
  TimeUs next() const { return heap_.empty() ? kNever : heap_.front().at; }
  // fn(frame) for every frame due by `now`, earliest first.
  template <typename Fn>
  void release(TimeUs now, Fn&& fn) {
    while (!heap_.empty() && heap_.front().at <= now) {
      std::pop_heap(heap_.begin(), heap_.end(), later);
      const CanFrame frame = heap_.back().frame;
      heap_.pop_back();
      fn(frame);
    }
  }
  void clear() { heap_.clear(); }

 private:
  struct Entry {
    TimeUs at;
    std::uint64_t seq;
    CanFrame frame;
  };
  static bool later(const Entry& a, const Entry& b) { return a.at != b.at ? a.at > b.at : a.seq > b.seq; }

  std::size_t capacity_;
  std::vector<Entry> heap_;
  std::uint64_t seq_ = 0;
};

}  // namespace cansim::io
