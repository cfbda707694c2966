// What the runtime control API (src/control, docs/control-api.md) and the
// PDO views ask of a node's measurement, and nothing more: its channels, the
// process model behind them, reported-value overrides, the fault schedule
// and the CSV recording. A pure interface: control never knows the
// personality's class, nor its chain or device part. Every sensor
// application implements it once (SensorApplication, sensor_application.cpp);
// the control verbs hold / step / ramp are built on it here.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/application.hpp"
#include "personalities/cia404.hpp"
#include "personalities/comm_faults.hpp"

namespace cansim::personalities {

class MeasurementControl {
 public:
  using ChannelView = Cia404Chain::ChannelView;
  using OverrideView = Cia404Chain::OverrideView;
  using EntryScale = Cia404Chain::EntryScale;

  // ---- channels (a physics channel is served by the first chain channel with that source)
  virtual bool has_channel(physics::Channel ch) const = 0;
  virtual ChannelView view(Node& node, physics::Channel ch, TimeUs now) = 0;
  // What a raw value of entry `e` means (unit and scale of a valued object).
  virtual EntryScale entry_scale(const Node& node, const OdEntry& e) const = 0;

  // ---- the process model: from `now` on (the terms' time 0 is `now`); false,
  // changing nothing, without a process model (a test's fake source). Throws
  // std::invalid_argument, changing nothing, on invalid terms.
  virtual bool set_process(Node& node, physics::Channel ch, const std::vector<physics::TermSpec>& terms,
                           TimeUs now) = 0;
  virtual bool restore_process(Node& node, physics::Channel ch, TimeUs now) = 0;  // back to the profile's model
  // The process model's value, Pa / K (NaN without a process model).
  virtual double true_value_si(physics::Channel ch, TimeUs now) = 0;
  // The control verbs: the true value stays at its present level / is `si` /
  // ramps linearly from its present level to `si` over `seconds` (>= 0).
  bool hold(Node& node, physics::Channel ch, TimeUs now);
  bool step(Node& node, physics::Channel ch, double si, TimeUs now);
  bool ramp(Node& node, physics::Channel ch, double si, double seconds, TimeUs now);

  // ---- what the node reports: `si` (Pa / K) on the channel; nullopt clears.
  virtual void set_override(Node& node, physics::Channel ch, std::optional<double> si, TimeUs now) = 0;
  virtual std::vector<OverrideView> overrides() const = 0;

  // ---- the fault schedule (DevicePart); kInvalidFaultHandle / false / none
  // without one. The listener hears every start / end edge (DevicePart).
  virtual physics::FaultHandle arm_fault(Node& node, const physics::FaultSpec& spec, TimeUs now) = 0;
  virtual bool cancel_fault(Node& node, physics::FaultHandle h, TimeUs now) = 0;
  virtual std::vector<physics::FaultInfo> faults(TimeUs now) const = 0;
  virtual void set_fault_listener(FaultListener listener) = 0;

  // ---- the CSV recording of the sensor; false with *error when the file
  // cannot be created or the node has no sensor. The node's checks that skip
  // a sensor sure to stay as it is take a row each again from `now` on
  // (Cia404Chain::status_steady_until).
  virtual bool start_recording(Node& node, const std::string& path, std::string* error, TimeUs now) = 0;
  virtual void stop_recording() = 0;
  virtual const std::string& recording() const = 0;  // "" when none

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
