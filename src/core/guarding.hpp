// Node guarding and life guarding, 0x100C / 0x100D (CiA 301 §7.2.8.3.1).
//
// Guarding exists only when the profile has 0x100C. An RTR on 0x700+id is
// answered with [state | toggle << 7]; the toggle starts at 0 after a reset
// communication and alternates with every answer. Choice (CiA 301 §7.2.8.1:
// a device uses heartbeat when 0x1017 != 0): RTRs are answered only while the
// heartbeat producer is off, unless option guarding_with_heartbeat is set.
// Life guarding: life time = 0x100C guard time × 0x100D factor (0 = off); it
// starts with the first RTR, every RTR restarts it; when it elapses: EMCY
// 0x8130 (option heartbeat_consumer_emcy) + 0x1029 reaction; the next RTR
// clears the error.
#pragma once

#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/node_service.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;

class NodeGuarding : private NodeService {
 public:
  explicit NodeGuarding(Node& node) : NodeService(node) {}
  // Its slots of the node's deadline board (core/node_service.hpp).
  static constexpr DeadlineSlots kDeadlines{DeadlineSlot::kGuarding};
  bool life_guard_failed() const { return failed_; }
  TimeUs life_time() const { return life_time_; }

  // The NodeService contract (core/node_service.hpp):
  void reset(TimeUs now);
  bool on_frame(const CanFrame& frame, TimeUs now);
  void process(TimeUs now);
  TimeUs next_deadline() const { return next_; }
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  bool owns(std::uint16_t index) const;
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

 private:
  void read_life_time();
  bool answers() const;

  Deadline next_{node_, kDeadlines.first};
  TimeUs life_time_ = 0;
  bool supported_ = false;
  bool toggle_ = false;
  bool failed_ = false;
};

}  // namespace cansim
