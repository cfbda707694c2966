// The network faults of a node's fault schedule (frame faults,
// node_id_collision, babbling, the SDO faults, clock_drift, error_frames)
// put in force on the node's core parts (core/frame_faults, core/
// disturbance, SdoServer::set_faults, Node::set_twin / set_clock_drift),
// from the schedule's state at `now`. Called by the communication fault
// driver at power-on and at every fault edge (comm_faults.hpp); idempotent:
// a fault in force stays as it is (its generator, a frozen frame, a twin),
// one that ended is taken away. Each fault's randomness is seeded from the
// schedule's seed (the fleet seed) and its handle.
#pragma once

#include "core/node.hpp"
#include "physics/fault.hpp"

namespace cansim::personalities {

void apply_network_faults(Node& node, const physics::FaultSet& faults, TimeUs now);

}  // namespace cansim::personalities
