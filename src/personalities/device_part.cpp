#include "personalities/device_part.hpp"

namespace cansim::personalities {

physics::FaultHandle DevicePart::arm_fault(Node& node, physics::FaultSet* faults, const physics::FaultSpec& spec,
                                           TimeUs now) {
  if (!faults) return physics::kInvalidFaultHandle;
  const physics::FaultHandle h = faults->add(spec, now);
  schedule_changed(node, now);
  return h;
}

bool DevicePart::cancel_fault(Node& node, physics::FaultSet* faults, physics::FaultHandle h, TimeUs now) {
  if (!faults) return false;
  const physics::FaultSpec* spec = faults->spec(h);
  // The node is in this cycle's off time: power comes back now (an unpowered
  // node runs no environment step, so the end edge alone would not boot it).
  const bool powered_off_by_it =
      spec && spec->kind == physics::FaultKind::PowerCycle && faults->active(h, now) && !node.powered();
  if (!faults->cancel(h, now)) return false;
  schedule_changed(node, now);
  if (powered_off_by_it) node.power_on(now);
  return true;
}

void DevicePart::schedule_changed(Node& node, TimeUs now) {
  comm_faults_.changed();
  node.wake_environment(now);
  node.wake_app(now);  // the device sees a fault that starts now at once
}

std::vector<physics::FaultInfo> DevicePart::armed_faults(const physics::FaultSet* faults, TimeUs now) {
  return faults ? faults->armed_faults(now) : std::vector<physics::FaultInfo>{};
}

void saturating_count(Node& node, const OdEntry* counter, std::uint64_t max) {
  if (!counter) return;
  const std::uint64_t n = node.values().get_u(*counter);
  if (n < max) node.values().set_u(*counter, n + 1);
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
    case Span::kOver: return v <= end - hysteresis && move_to(Span::kInside);
    case Span::kUnder: return v >= start + hysteresis && move_to(Span::kInside);
  }
  return false;
}

}  // namespace cansim::personalities
