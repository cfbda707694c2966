#include "personalities/device_part.hpp"

namespace cansim::personalities {

physics::FaultHandle DevicePart::arm_fault(Node& node, Cia404Chain& chain, const physics::FaultSpec& spec,
                                           TimeUs now) {
  physics::FaultSet* set = chain.fault_set();
  if (!set) return physics::kInvalidFaultHandle;
  const physics::FaultHandle h = set->add(spec, now);
  schedule_changed(node, chain, now);
  return h;
}

bool DevicePart::cancel_fault(Node& node, Cia404Chain& chain, physics::FaultHandle h, TimeUs now) {
  physics::FaultSet* set = chain.fault_set();
  if (!set) return false;
  const physics::FaultSpec* spec = set->spec(h);
  // The node is in this cycle's off time: power comes back now (an unpowered
  // node runs no environment step, so the end edge alone would not boot it).
  const bool powered_off_by_it =
      spec && spec->kind == physics::FaultKind::PowerCycle && set->active(h, now) && !node.powered();
  if (!set->cancel(h, now)) return false;
  schedule_changed(node, chain, now);
  if (powered_off_by_it) node.power_on(now);
  return true;
}

void DevicePart::schedule_changed(Node& node, Cia404Chain& chain, TimeUs now) {
  comm_faults_.changed();
  chain.invalidate();
  node.wake_environment(now);
  node.wake_app(now);  // the device sees a fault that starts now at once
}

std::vector<physics::FaultInfo> DevicePart::faults(const Cia404Chain& chain, TimeUs now) {
  const physics::FaultSet* set = chain.fault_set();
  return set ? set->armed_faults(now) : std::vector<physics::FaultInfo>{};
}

bool DevicePart::fault_active(const Cia404Chain& chain, physics::FaultKind kind, TimeUs now) {
  const physics::FaultSet* set = chain.fault_set();
  return set && set->active(kind, now);
}

void saturating_count(Node& node, const OdEntry* counter, std::uint64_t max) {
  if (!counter) return;
  const std::uint64_t n = node.values().get_u(*counter);
  if (n < max) node.values().set_u(*counter, n + 1);
}

void follow_emcy(Node& node, bool& reported, bool active, std::uint16_t code, std::uint8_t reg, TimeUs now,
                 const std::uint8_t* mfr) {
  if (active == reported) return;
  reported = active;
  if (active) node.emcy().raise(code, reg, mfr, now);
  else node.emcy().clear(code, now);
}

Span SpanMonitor::of_status(std::uint8_t status) {
  return (status & physics::kStatusPositiveOverload)   ? Span::kOver
         : (status & physics::kStatusNegativeOverload) ? Span::kUnder
                                                       : Span::kInside;
}

bool SpanMonitor::track(double v, double start, double end, double hysteresis) {
  switch (span) {
    case Span::kInside:
      if (v > end) return move_to(Span::kOver);
      if (v < start) return move_to(Span::kUnder);
      return false;
    case Span::kOver:
      return v <= end - hysteresis && move_to(Span::kInside);
    case Span::kUnder:
      return v >= start + hysteresis && move_to(Span::kInside);
  }
  return false;
}

}  // namespace cansim::personalities
