// Communication faults of one node, from its fault schedule (physics::FaultSet)
// to the switches of the core: silent, power cycle, bus-off, heartbeat stop,
// slow SDO answers, dropped SDO block segments. (Measurement faults act in the
// sensor chain; EEPROM / data-set errors are read by the personality at boot.)
//
// Runs as the application's environment step (Application::environment): at
// power-on before the boot-up, and at each fault edge before the services of
// that instant. Levels are applied idempotently, so a fault that outlasts a
// power cycle is in force again when the node is back.
//
// It polls the edges of every fault, measurement faults included, so it runs
// at the next edge of any fault: a listener hears each edge then.
//
// A value: it keeps no pointer into the schedule (the owner passes it), so a
// copy of the device part it belongs to is a snapshot. The listener is
// wiring, not state: a copy starts without one, an assignment keeps its own.
#pragma once

#include <functional>

#include "core/node.hpp"
#include "physics/fault.hpp"

namespace cansim::personalities {

// Told of a fault's start / end edge (edge.time_us: when it was due).
using FaultListener = std::function<void(const physics::FaultEdge&)>;

// A listener slot with wiring semantics (see above).
class FaultListenerSlot {
 public:
  FaultListenerSlot() = default;
  FaultListenerSlot(const FaultListenerSlot&) {}
  FaultListenerSlot& operator=(const FaultListenerSlot&) { return *this; }
  void set(FaultListener listener) { listener_ = std::move(listener); }
  void operator()(const physics::FaultEdge& edge) const {
    if (listener_) listener_(edge);
  }

 private:
  FaultListener listener_;
};

class CommFaultDriver {
 public:
  // seed: varies the dropped SDO segments from node to node.
  explicit CommFaultDriver(std::uint64_t seed) : seed_(seed) {}

  // Applies what of `faults` (null: none) is due at `now`; returns the next
  // fault edge. May power-cycle the node.
  TimeUs apply(Node& node, physics::FaultSet* faults, TimeUs now);
  // A fault was armed or cancelled at run time (the set may have moved its entries).
  void changed() { drop_ = physics::kInvalidFaultHandle; }
  void set_listener(FaultListener listener) { listener_.set(std::move(listener)); }

 private:
  void apply_levels(Node& node, physics::FaultSet& faults, TimeUs now);

  std::uint64_t seed_;
  physics::FaultHandle drop_ = physics::kInvalidFaultHandle;  // the SDO block drop in force
  FaultListenerSlot listener_;
};

}  // namespace cansim::personalities
