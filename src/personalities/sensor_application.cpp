#include "personalities/sensor_application.hpp"

namespace cansim::personalities {

// A changed schedule changes what the chain measures from `now` on.
physics::FaultHandle SensorApplication::arm_fault(Node& node, const physics::FaultSpec& spec, TimeUs now) {
  const physics::FaultHandle h = device_.arm_fault(node, chain_.fault_set(), spec, now);
  if (h != physics::kInvalidFaultHandle) chain_.invalidate();
  return h;
}

bool SensorApplication::cancel_fault(Node& node, physics::FaultHandle h, TimeUs now) {
  if (!device_.cancel_fault(node, chain_.fault_set(), h, now)) return false;
  chain_.invalidate();
  return true;
}

// A recording wants a row at every check: the chain measures again.
bool SensorApplication::start_recording(Node& node, const std::string& path, std::string* error, TimeUs now) {
  if (!chain_.start_recording(path, error)) return false;
  chain_.invalidate();
  node.wake_app(now);
  return true;
}

}  // namespace cansim::personalities
