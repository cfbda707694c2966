#include "personalities/comm_faults.hpp"

#include <algorithm>

namespace cansim::personalities {

using physics::FaultKind;

TimeUs CommFaultDriver::apply(Node& node, TimeUs now) {
  if (!faults_) return kNever;
  physics::FaultEdge edge;
  while (faults_->poll(now, edge)) {
    if (edge.kind != FaultKind::PowerCycle || !edge.started) continue;
    // Off for the fault's duration (none given: an immediate reboot), counted
    // from the scheduled edge so a late poll does not stretch it.
    const TimeUs off = std::max<TimeUs>(edge.spec->timing.duration_us, 0);
    node.power_cycle(now, std::max<TimeUs>(edge.time_us + off - now, 0));
    return kNever;  // power-on runs us again
  }
  apply_levels(node, now);
  return faults_->next_edge_time();
}

void CommFaultDriver::apply_levels(Node& node, TimeUs now) {
  node.set_muted(faults_->active(FaultKind::Silent, now));
  node.set_bus_off(faults_->active(FaultKind::BusOff, now), now);
  node.heartbeat().set_producer_stopped(faults_->active(FaultKind::HeartbeatStop, now));
  const physics::FaultSpec* slow = faults_->active_spec(FaultKind::SlowSdo, now);
  node.sdo().set_response_delay(slow ? slow->sdo_delay_us : 0);
  const physics::FaultSpec* drop = faults_->active_spec(FaultKind::SdoBlockDrop, now);
  if (drop != drop_spec_) {
    drop_spec_ = drop;
    if (drop)
      node.sdo().set_block_drop(drop->drop_every_n, drop->drop_probability, 0x9E3779B97F4A7C15ull ^ drop->id);
    else
      node.sdo().set_block_drop(0, 0.0, 0);
  }
}

}  // namespace cansim::personalities
