// NMT slave state machine, boot-up and reset sequences (CiA 301 §7.3.2).
#pragma once

#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;

// NMT states as the heartbeat byte encodes them (CiA 301 Table 58).
enum class NmtState : std::uint8_t {
  kInitialising = 0x00,
  kStopped = 0x04,
  kOperational = 0x05,
  kPreOperational = 0x7F,
};

class NmtSlave {
 public:
  explicit NmtSlave(Node& node) : node_(node) {}
  // Power-on: initialisation, boot-up, then pre-operational (or operational).
  void power_on(TimeUs now);
  NmtState state() const { return state_; }
  // Executes an NMT command specifier (0x01, 0x02, 0x80, 0x81, 0x82) locally.
  void command(std::uint8_t cs, TimeUs now);
  // Re-reads its configuration from the OD (after a reset / power-on).
  void reset(TimeUs now);
  // Returns true when the frame was addressed to this service.
  bool on_frame(const CanFrame& frame, TimeUs now);
  // Runs the work due at or before now.
  void process(TimeUs now);
  TimeUs next_deadline() const { return next_; }
  // COB-IDs this service wants to receive (for the bus dispatcher).
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  // True for OD indices whose remote writes this service handles itself.
  bool owns(std::uint16_t index) const;
  // A checked remote write of an owned entry: validate, store, react.
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

 private:
  Node& node_;
  TimeUs next_ = kNever;
  NmtState state_ = NmtState::kInitialising;
};

}  // namespace cansim
