// Heartbeat producer 0x1017 and consumer 0x1016 (CiA 301 §7.2.8.3.2).
//
// Producer: 0x700+id [state] every 0x1017 ms, first one period after the
// boot-up (start()) or after a write of 0x1017; deadlines are absolute
// (t0 + k·period) so the period never drifts.
// Consumer: each 0x1016 sub = node-ID (bits 23-16) + time ms (bits 15-0);
// monitoring of an entry starts with the first heartbeat from that node (a
// boot-up re-arms it); a timeout raises EMCY (option heartbeat_consumer_emcy,
// 0x8130 by default) and runs the 0x1029 reaction; the EMCY clears when every
// failed producer beats again.
#pragma once

#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/node_service.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;

class Heartbeat : private NodeService {
 public:
  explicit Heartbeat(Node& node) : NodeService(node) {}
  // Its slots of the node's deadline board (core/node_service.hpp).
  static constexpr DeadlineSlots kDeadlines{DeadlineSlot::kHeartbeat};
  // Starts the producer (called by NMT at the boot-up).
  void start(TimeUs now);
  std::uint16_t producer_time_ms() const { return period_ms_; }
  // True while at least one consumer entry timed out and did not recover.
  bool consumer_failed() const { return failed_count_ > 0; }
  // Fault injection "heartbeat stops": the producer keeps its schedule but
  // sends nothing, so it resumes on the same grid.
  void set_producer_stopped(bool stopped) { producer_stopped_ = stopped; }
  bool producer_stopped() const { return producer_stopped_; }

  // The NodeService contract (core/node_service.hpp):
  void reset(TimeUs now);
  bool on_frame(const CanFrame& frame, TimeUs now);
  void process(TimeUs now);
  TimeUs next_deadline() const { return next_; }
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  bool owns(std::uint16_t index) const;
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

 private:
  enum class Watch : std::uint8_t { kOff, kWaiting, kActive, kTimedOut };
  struct Consumer {
    std::uint8_t node_id = 0;
    std::uint16_t time_ms = 0;
    Watch watch = Watch::kOff;
    TimeUs deadline = kNever;
  };

  void configure(Consumer& c, std::uint32_t value);
  void on_heartbeat(Consumer& c, std::uint8_t state, TimeUs now);
  void time_out(Consumer& c, TimeUs now);
  void update_deadline();

  Deadline next_{node_, kDeadlines.first};
  TimeUs next_beat_ = kNever;
  std::uint16_t period_ms_ = 0;
  std::uint16_t failed_count_ = 0;
  bool producer_stopped_ = false;
  std::vector<Consumer> consumers_;  // one per 0x1016 sub, sized at reset
};

}  // namespace cansim
