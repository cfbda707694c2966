// TPDO / RPDO engine: 0x1400-0x1BFF (CiA 301 §7.2.2).
#pragma once

#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;

class PdoEngine {
 public:
  explicit PdoEngine(Node& node) : node_(node) {}
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

  // Called by the SYNC consumer on every SYNC received (counter 0 when the
  // SYNC carries no counter, CiA 301 §7.2.5).
  void on_sync(std::uint8_t counter, TimeUs now);
  // Application events (CiA 301 §7.2.2.2, types 0/254/255): 1-based TPDO number.
  void raise_event(unsigned tpdo_number);
  // Raises an event on every valid event-driven/acyclic TPDO that maps `e`.
  void raise_event_for(const OdEntry& e);

 private:
  Node& node_;
  TimeUs next_ = kNever;
};

}  // namespace cansim
