// The CiA 404 chain's fault glue: the node's fault schedule (measurement
// faults in the sensor, communication faults in the CommFaultDriver), armed
// from the profile at boot and by the control API at run time.
#include "personalities/cia404.hpp"

namespace cansim::personalities {

TimeUs Cia404Application::environment(Node& node, TimeUs now) { return comm_faults_.apply(node, now); }

physics::FaultHandle Cia404Application::arm_fault(Node& node, const physics::FaultSpec& spec, TimeUs now) {
  physics::FaultSet* set = source_->fault_set();
  if (!set) return physics::kInvalidFaultHandle;
  const physics::FaultHandle h = set->add(spec, now);
  fault_schedule_changed(node, now);
  return h;
}

bool Cia404Application::cancel_fault(Node& node, physics::FaultHandle h, TimeUs now) {
  physics::FaultSet* set = source_->fault_set();
  if (!set) return false;
  const physics::FaultSpec* spec = set->spec(h);
  // The node is in this cycle's off time: power comes back now (an unpowered
  // node runs no environment step, so the end edge alone would not boot it).
  const bool powered_off_by_it =
      spec && spec->kind == physics::FaultKind::PowerCycle && set->active(h, now) && !node.powered();
  if (!set->cancel(h, now)) return false;
  fault_schedule_changed(node, now);
  if (powered_off_by_it) node.power_on(now);
  return true;
}

void Cia404Application::fault_schedule_changed(Node& node, TimeUs now) {
  comm_faults_.changed();
  invalidate();
  node.wake_environment(now);
}

std::vector<physics::FaultInfo> Cia404Application::faults(TimeUs now) const {
  const physics::FaultSet* set = source_->fault_set();
  return set ? set->armed_faults(now) : std::vector<physics::FaultInfo>{};
}

}  // namespace cansim::personalities
