// What an outside observer (the runtime control API, a test) learns from a
// node: NMT state changes, the frames that really left (boot-up, EMCY), what a
// master wrote, power edges. Set per node with Node::set_observer; without
// one the cost is a null-pointer check where the event happens.
//
// Callbacks run synchronously inside the node's own processing (a frame, an
// advance, a local operation) and carry the time of the event. They must not
// call back into the node's mutating API; record what happened and act later.
#pragma once

#include <cstdint>

#include "core/can_frame.hpp"
#include "core/od.hpp"

namespace cansim {

class Node;
enum class NmtState : std::uint8_t;

// How a master's write reached the object dictionary.
enum class WriteVia : std::uint8_t { kSdo, kRpdo };

class NodeObserver {
 public:
  virtual ~NodeObserver() = default;
  // Every NMT state change: master or local command, reset (to INITIALISING),
  // boot-up (INITIALISING -> PRE-OPERATIONAL), error reaction, power loss
  // (to INITIALISING). Reported before the services react to it.
  virtual void on_nmt_state(Node&, NmtState /*old*/, NmtState /*now*/, TimeUs) {}
  // The boot-up frame was handed to the sink (not when off the bus / silent).
  virtual void on_boot_up(Node&, TimeUs) {}
  // An EMCY frame was handed to the sink (after the 0x1015 inhibit queue).
  virtual void on_emcy(Node&, std::uint16_t /*code*/, std::uint8_t /*reg*/, const std::uint8_t /*vendor*/[5], TimeUs) {}
  // A master's write was stored: an SDO download (expedited, segmented,
  // block) or one object of a received RPDO. Local writes are not reported.
  virtual void on_remote_write(Node&, const OdEntry&, WriteVia, TimeUs) {}
  // Power cut (power_cycle, power_off(now)) and power back (power_on).
  virtual void on_power(Node&, bool /*powered*/, TimeUs) {}
  // What the node's PDOs carry may have changed: the PDO configuration was
  // (re)loaded (reset, power-on, a COB-ID / type / mapping write by any path)
  // or the application changed the scaling of a mappable value (CiA 404
  // 0x6131 unit, 0x6132 decimal digits).
  virtual void on_pdo_config(Node&, TimeUs) {}
};

}  // namespace cansim
