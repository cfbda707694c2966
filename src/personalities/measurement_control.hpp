// What the runtime control API (src/control, docs/control-api.md) asks of a
// node's measurement: its process model, reported-value overrides, channel
// views, the fault schedule and the CSV recording. An interface: control
// never knows the personality's class. Every sensor application offers it
// over its chain and device part (sensor_application.hpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/application.hpp"
#include "personalities/cia404.hpp"
#include "personalities/device_part.hpp"

namespace cansim::personalities {

class MeasurementControl {
 public:
  using ChannelView = Cia404Chain::ChannelView;
  using OverrideView = Cia404Chain::OverrideView;

  // The parts the control acts on.
  virtual Cia404Chain& chain() = 0;
  virtual const Cia404Chain& chain() const = 0;
  virtual DevicePart& device() = 0;

  // ---- the process model (Cia404Chain has the details)
  std::optional<std::size_t> chain_channel(physics::Channel ch) const { return chain().chain_channel(ch); }
  bool has_channel(physics::Channel ch) const { return chain().has_channel(ch); }
  bool has_process() const { return chain().has_process(); }
  bool set_process(Node& node, physics::Channel ch, const std::vector<physics::TermSpec>& terms, TimeUs now) {
    return chain().set_process(node, ch, terms, now);
  }
  bool restore_process(Node& node, physics::Channel ch, TimeUs now) { return chain().restore_process(node, ch, now); }
  bool hold(Node& node, physics::Channel ch, TimeUs now) { return chain().hold(node, ch, now); }
  bool step(Node& node, physics::Channel ch, double si, TimeUs now) { return chain().step(node, ch, si, now); }
  bool ramp(Node& node, physics::Channel ch, double si, double seconds, TimeUs now) {
    return chain().ramp(node, ch, si, seconds, now);
  }
  double true_value_si(physics::Channel ch, TimeUs now) { return chain().true_value_si(ch, now); }
  ChannelView view(Node& node, physics::Channel ch, TimeUs now) { return chain().view(node, ch, now); }

  // ---- what the node reports
  void set_override(Node& node, physics::Channel ch, std::optional<double> si, TimeUs now) {
    chain().set_override(node, ch, si, now);
  }
  std::vector<OverrideView> overrides() const { return chain().overrides(); }

  // ---- the fault schedule (DevicePart has the details)
  physics::FaultHandle arm_fault(Node& node, const physics::FaultSpec& spec, TimeUs now) {
    return device().arm_fault(node, chain(), spec, now);
  }
  bool cancel_fault(Node& node, physics::FaultHandle h, TimeUs now) { return device().cancel_fault(node, chain(), h, now); }
  std::vector<physics::FaultInfo> faults(TimeUs now) const { return DevicePart::faults(chain(), now); }
  bool fault_active(physics::FaultKind kind, TimeUs now) const { return DevicePart::fault_active(chain(), kind, now); }
  void set_fault_listener(FaultListener listener) { device().set_fault_listener(std::move(listener)); }

  // ---- the CSV recording of the sensor
  bool start_recording(const std::string& path, std::string* error) { return chain().start_recording(path, error); }
  void stop_recording() { chain().stop_recording(); }
  const std::string& recording() const { return chain().recording(); }

 protected:
  MeasurementControl() = default;
  MeasurementControl(const MeasurementControl&) = default;
  MeasurementControl& operator=(const MeasurementControl&) = default;
  ~MeasurementControl() = default;
};

// The measurement control of a node's application (null: none, e.g. a plain
// CiA 301 node or a test's application). Pass the personality's own
// application, not a wrapper.
MeasurementControl* measurement_control(Application* app);

}  // namespace cansim::personalities
