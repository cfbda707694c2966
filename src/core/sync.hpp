// SYNC consumer: 0x1005, 0x1006, 0x1007, 0x1019 (CiA 301 §7.2.5, §7.5.2.5-7,
// §7.5.2.40). The node consumes SYNC only; it never produces it.
//
// A SYNC is valid when its DLC is 0 (0x1019 = 0) or 1 (0x1019 = 2..240, byte 0
// = counter); any other DLC raises EMCY 0x8240 (a one-shot report) and the
// frame is ignored. Valid SYNCs in PRE-OPERATIONAL / OPERATIONAL go to the
// PDO engine and the application; a SYNC opens the synchronous window 0x1007.
#pragma once

#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/node_service.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;

class SyncConsumer : private NodeService {
 public:
  explicit SyncConsumer(Node& node) : NodeService(node) {}
  // Its slots of the node's deadline board (core/node_service.hpp).
  static constexpr DeadlineSlots kDeadlines{DeadlineSlot::kSync};
  // True while synchronous PDOs may be sent: within 0x1007 µs after the last
  // SYNC (always, when 0x1007 = 0).
  bool window_open(TimeUs now) const;
  std::uint32_t cob_id() const { return cob_id_; }
  std::uint8_t overflow() const { return overflow_; }
  TimeUs last_sync() const { return last_sync_; }

  // The NodeService contract (core/node_service.hpp):
  void reset(TimeUs now);
  bool on_frame(const CanFrame& frame, TimeUs now);
  void process(TimeUs now);
  TimeUs next_deadline() const { return next_; }
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  bool owns(std::uint16_t index) const;
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

 private:
  void read_config();
  SdoAbort write_cob_id(const OdEntry& e, std::uint32_t v);
  SdoAbort write_overflow(const OdEntry& e, std::uint8_t v);

  Deadline next_{node_, kDeadlines.first};
  TimeUs last_sync_ = kNever;
  TimeUs window_us_ = 0;
  std::uint32_t cob_id_ = 0;  // CAN-ID, with CanFrame::kExtended in extended_
  bool extended_ = false;
  bool present_ = false;
  std::uint8_t overflow_ = 0;
};

}  // namespace cansim
