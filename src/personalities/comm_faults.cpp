#include "personalities/comm_faults.hpp"

#include <algorithm>

#include "personalities/network_faults.hpp"
#include "physics/random.hpp"

namespace cansim::personalities {

using physics::FaultKind;

TimeUs CommFaultDriver::apply(Node& node, physics::FaultSet* faults, TimeUs now) {
  if (!faults) return kNever;
  physics::FaultEdge edge;
  while (faults->poll(now, edge)) {
    listener_(edge);
    if (edge.kind != FaultKind::PowerCycle || !edge.started) continue;
    // Off for the fault's duration (none given: an immediate reboot), counted
    // from the scheduled edge so a late poll does not stretch it. A cycle
    // that is already over (a node added long after it) is history.
    const TimeUs off = std::max<TimeUs>(edge.spec->timing.duration_us, 0);
    if (edge.time_us + off < now) continue;
    node.power_cycle(now, edge.time_us + off - now);
    return kNever;  // power-on runs us again
  }
  apply_levels(node, *faults, now);
  return faults->next_edge_time();
}

namespace {
physics::FaultHandle handle_of(const physics::FaultSet& faults, const physics::FaultSpec* spec) {
  for (physics::FaultHandle h = 0; h < faults.size(); ++h)
    if (faults.spec(h) == spec) return h;
  return physics::kInvalidFaultHandle;
}
}  // namespace

void CommFaultDriver::apply_levels(Node& node, physics::FaultSet& faults, TimeUs now) {
  apply_network_faults(node, faults, now);
  node.set_muted(faults.active(FaultKind::Silent, now));
  node.set_bus_off(faults.active(FaultKind::BusOff, now), now);
  node.heartbeat().set_producer_stopped(faults.active(FaultKind::HeartbeatStop, now));
  const physics::FaultSpec* slow = faults.active_spec(FaultKind::SlowSdo, now);
  node.sdo().set_response_delay(slow ? slow->sdo_delay_us : 0);
  const physics::FaultSpec* drop = faults.active_spec(FaultKind::SdoBlockDrop, now);
  const physics::FaultSpec* before = drop_ == physics::kInvalidFaultHandle ? nullptr : faults.spec(drop_);
  if (drop == before) return;
  drop_ = handle_of(faults, drop);
  if (drop)
    node.sdo().set_block_drop(drop->drop_every_n, drop->drop_probability,
                              physics::derive_seed(seed_, 0x5D0B10C0ull ^ drop->id));
  else node.sdo().set_block_drop(0, 0.0, 0);
}

}  // namespace cansim::personalities
