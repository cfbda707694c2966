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
#pragma once

#include <functional>

#include "core/node.hpp"
#include "physics/fault.hpp"

namespace cansim::personalities {

// Told of a fault's start / end edge (edge.time_us: when it was due).
using FaultListener = std::function<void(const physics::FaultEdge&)>;

class CommFaultDriver {
 public:
  // seed: varies the dropped SDO segments from node to node.
  CommFaultDriver(physics::FaultSet* faults, std::uint64_t seed) : faults_(faults), seed_(seed) {}

  // Applies what is due at `now`; returns the next fault edge. May
  // power-cycle the node.
  TimeUs apply(Node& node, TimeUs now);
  // A fault was armed or cancelled at run time (the set may have moved its entries).
  void changed() { drop_spec_ = nullptr; }
  void set_listener(FaultListener listener) { listener_ = std::move(listener); }
  // Takes the state of a driver of a copy of this schedule (Cia404Application
  // snapshots; the owner restores the schedule); the listener stays.
  void restore(const CommFaultDriver& snapshot);

 private:
  void apply_levels(Node& node, TimeUs now);

  physics::FaultSet* faults_;
  std::uint64_t seed_;
  const physics::FaultSpec* drop_spec_ = nullptr;
  FaultListener listener_;
};

}  // namespace cansim::personalities
