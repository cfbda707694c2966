#include "personalities/comm_faults.hpp"

#include <algorithm>

#include "physics/random.hpp"

namespace cansim::personalities {

using physics::FaultKind;

TimeUs CommFaultDriver::apply(Node& node, TimeUs now) {
  if (!faults_) return kNever;
  physics::FaultEdge edge;
  while (faults_->poll(now, edge)) {
    if (listener_) listener_(edge);
    if (edge.kind != FaultKind::PowerCycle || !edge.started) continue;
    // Off for the fault's duration (none given: an immediate reboot), counted
    // from the scheduled edge so a late poll does not stretch it. A cycle
    // that is already over (a node added long after it) is history.
    const TimeUs off = std::max<TimeUs>(edge.spec->timing.duration_us, 0);
    if (edge.time_us + off < now) continue;
    node.power_cycle(now, edge.time_us + off - now);
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
      node.sdo().set_block_drop(drop->drop_every_n, drop->drop_probability,
                                physics::derive_seed(seed_, 0x5D0B10C0ull ^ drop->id));
    else
      node.sdo().set_block_drop(0, 0.0, 0);
  }
}

// The SDO block-drop fault in force is the same entry of the copied schedule.
void CommFaultDriver::restore(const CommFaultDriver& snapshot) {
  seed_ = snapshot.seed_;
  drop_spec_ = nullptr;
  if (!snapshot.drop_spec_ || !faults_) return;
  for (physics::FaultHandle h = 0; h < snapshot.faults_->size(); ++h)
    if (snapshot.faults_->spec(h) == snapshot.drop_spec_) drop_spec_ = faults_->spec(h);
}

}  // namespace cansim::personalities
