#include "personalities/measurement_control.hpp"

namespace cansim::personalities {

bool MeasurementControl::hold(Node& node, physics::Channel ch, TimeUs now) {
  return step(node, ch, true_value_si(ch, now), now);
}

bool MeasurementControl::step(Node& node, physics::Channel ch, double si, TimeUs now) {
  return set_process(node, ch, physics::constant_terms(si), now);
}

bool MeasurementControl::ramp(Node& node, physics::Channel ch, double si, double seconds, TimeUs now) {
  return set_process(node, ch, physics::ramp_terms(true_value_si(ch, now), si, 0.0, seconds), now);
}

MeasurementControl* measurement_control(Application* app) { return dynamic_cast<MeasurementControl*>(app); }

}  // namespace cansim::personalities
