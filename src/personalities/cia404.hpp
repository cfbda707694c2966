// The CiA 404 measurement chain, shared by every sensor personality.
//
// One chain per analogue-input channel (channel n = sub-index n of the 0x61xx
// objects). A channel's logical values (PV, offset, span, limits, ...) are each
// seen through up to four OD views: REAL32 (0x61xx) and the INTEGER16
// (0x71xx) / INTEGER24 (0x81xx) / INTEGER32 (0x91xx) twins, whose integers are value x 10^digits
// (0x6132). Which objects exist, their types, the accepted units and which
// objects follow a unit change are profile data; a device personality
// derives from Cia404Application and overrides only what its manual says
// differs (see the virtual hooks).
//
//   source (physics::Sensor, SI) -> unit 0x6131 -> + offset 0x6124 -> PV 0x6130 / 0x7130 / 0x9130
//   raw ADC counts -> FV 0x6100 / 0x7100 / 0x9100;  span 0x6148/0x6149 -> status 0x6150
//   delta 0x6133, limits 0x6134/0x6135 with hysteresis 0x6136 -> TPDO events (type 254/255)
//
// Files: cia404.cpp the chain and its events, cia404_faults.cpp the fault
// glue, cia404_control.cpp the control API hooks, sensor_source.* the
// physics adapter; the chain's profile data is model/cia404_profile.hpp.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/application.hpp"
#include "core/node.hpp"
#include "core/node_options.hpp"
#include "model/cia404_profile.hpp"
#include "model/device_settings.hpp"
#include "model/units.hpp"
#include "personalities/comm_faults.hpp"
#include "personalities/sensor_source.hpp"

namespace cansim::personalities {

// The chain's profile data (src/model/cia404_profile.hpp).
using model::ChannelConfig;
using model::Cia404Profile;
using model::Cia404Settings;
using model::DigitsOnUnitChange;
using model::IdentitySettings;
using model::kRoleCount;
using model::Param;
using model::QuantityKind;
using model::Role;
using model::UnitChoice;
using model::UnitScale;

// What one event check of a channel found (Cia404Application::on_channel_events).
enum : unsigned {
  kEventChange = 0x01,     // the mapped value changed (change_event_tpdo_types)
  kEventDelta = 0x02,      // |PV - reference| > delta
  kEventUpperUp = 0x04,    // PV rose above the upper limit
  kEventUpperDown = 0x08,  // PV fell back to upper limit - hysteresis (re-armed)
  kEventLowerDown = 0x10,  // PV fell below the lower limit
  kEventLowerUp = 0x20,    // PV rose back to lower limit + hysteresis (re-armed)
  kEventsRaising = kEventChange | kEventDelta | kEventUpperUp | kEventLowerDown,
};

// The per-node Application of a CiA 404 sensor. Device personalities derive
// from it; every override should call the base for the CiA 404 part.
class Cia404Application : public Application {
 public:
  Cia404Application(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                    IdentitySettings identity = {}, std::uint32_t node_index = 0);

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  void on_nmt_state(Node& node, NmtState state, TimeUs now) override;
  void on_pdo_config(Node& node, TimeUs now) override;
  void refresh(Node& node, const OdEntry& e, TimeUs now) override;
  SdoAbort check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) override;
  void after_write(Node& node, const OdEntry& e, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;
  TimeUs environment(Node& node, TimeUs now) override;
  // The chain state, the measurement source (physics, fault schedule) and
  // the communication faults. Null for a device personality deriving from
  // this class (its own state would be missing) or a source without snapshots.
  std::unique_ptr<Application> snapshot() const override;
  void restore(const Application& snapshot) override;

  // ---- the chain, for personalities and tests
  struct Measurement {
    double input = 0.0;       // source value in the current unit, before the offset
    double pv = 0.0;          // process value (input + offset)
    std::int32_t raw = 0;     // ADC counts
    std::uint8_t status = 0;  // 0x6150 bits
  };
  // Evaluates channel `ch` (index into profile().channels) at `now` and
  // stores the live objects (PV views, FV, status).
  Measurement measure(Node& node, std::size_t ch, TimeUs now);
  // A logical value in the channel's current unit (0 when the object is absent).
  double get(const Node& node, std::size_t ch, Role role) const;
  void set(Node& node, std::size_t ch, Role role, double value);
  const UnitScale& unit(std::size_t ch) const { return state_[ch].unit.scale; }
  // What a raw value of entry `e` means: a valued object of a channel (PV,
  // offset, span, limits) is in the channel's current unit, its integer views
  // x 10^digits (0x6132); anything else has no unit (scale 1, unit "").
  struct EntryScale {
    double scale = 1.0;        // engineering value = raw value x scale
    std::string_view unit;     // as the control API names it ("bar", "degC"); "" for none
  };
  EntryScale entry_scale(const Node& node, const OdEntry& e) const;
  const Cia404Profile& profile() const { return *profile_; }
  MeasurementSource& source() { return *source_; }

  // ---- fault injection at run time (the profile's faults are armed at boot)
  // Returns physics::kInvalidFaultHandle when the source has no fault schedule.
  physics::FaultHandle arm_fault(Node& node, const physics::FaultSpec& spec, TimeUs now);
  bool cancel_fault(Node& node, physics::FaultHandle h, TimeUs now);
  // Is a fault of this kind in force (false when the source has no schedule)?
  bool fault_active(physics::FaultKind kind, TimeUs now) {
    const physics::FaultSet* set = source_->fault_set();
    return set && set->active(kind, now);
  }
  // The faults still armed at `now` (ids = handles), profile faults included.
  std::vector<physics::FaultInfo> faults(TimeUs now) const;
  // Told of every start / end edge of every armed fault (measurement and
  // communication, profile and run time) when the node reaches it: at the
  // edge time, or at power-on for edges in a power-off time. The listener
  // must not arm or cancel faults.
  void set_fault_listener(FaultListener listener) { comm_faults_.set_listener(std::move(listener)); }

  // ---- runtime control: the hooks of the control API (docs/control-api.md).
  // A physics channel is served by the first chain channel with that source.
  // Each change acts at `now` and wakes the node, so PV reads, event TPDOs
  // and change events follow as for a sensor change.
  std::optional<std::size_t> chain_channel(physics::Channel ch) const;
  bool has_channel(physics::Channel ch) const { return chain_channel(ch).has_value(); }
  // The source has a process model (false: a test's fake source; then the
  // process methods below return false and change nothing).
  bool has_process() const { return sensor_ != nullptr; }
  // The channel's process model from `now` on (the terms' time 0 is `now`).
  // Throws std::invalid_argument, changing nothing, on invalid terms.
  bool set_process(Node& node, physics::Channel ch, const std::vector<physics::TermSpec>& terms, TimeUs now);
  bool restore_process(Node& node, physics::Channel ch, TimeUs now);  // back to the profile's model
  // The control verbs: the true value stays at its present level / is `si` /
  // ramps linearly from its present level to `si` over `seconds` (>= 0).
  bool hold(Node& node, physics::Channel ch, TimeUs now);
  bool step(Node& node, physics::Channel ch, double si, TimeUs now);
  bool ramp(Node& node, physics::Channel ch, double si, double seconds, TimeUs now);
  // The process model's value, Pa / K (NaN without a process model).
  double true_value_si(physics::Channel ch, TimeUs now);

  struct ChannelView {
    double true_value = std::numeric_limits<double>::quiet_NaN();  // in `unit`
    double reported = std::numeric_limits<double>::quiet_NaN();    // the PV the node answers
    std::string_view unit;    // the channel's current 0x6131 unit; "" without the channel
    std::uint8_t status = 0;  // 0x6150
  };
  ChannelView view(Node& node, physics::Channel ch, TimeUs now);

  // The node reports `si` (Pa / K) on the channel: PV views, events, TPDOs,
  // status valid; the sensor goes on (field value, recording). nullopt clears.
  void set_override(Node& node, physics::Channel ch, std::optional<double> si, TimeUs now);
  struct OverrideView {
    physics::Channel channel;
    double value;           // in `unit`
    std::string_view unit;  // the channel's current unit
  };
  std::vector<OverrideView> overrides() const;

  // CSV recording of the sensor (SensorSource::record_to); false with *error
  // when the file cannot be created or the source has no sensor.
  bool start_recording(const std::string& path, std::string* error);
  void stop_recording();
  const std::string& recording() const;  // "" when none

 protected:
  // ---- override points for device personalities
  // Source value -> value in the current unit before the offset.
  virtual double input_value(const ChannelConfig& c, const MeasurementSource::Sample& s, const UnitScale& unit) {
    (void)c;
    return unit.from_si(s.si);
  }
  // Hysteresis of the limit interrupts (CiA 404 0x6136; vendors may derive it).
  virtual double limit_hysteresis(const Node& node, std::size_t ch) const { return get(node, ch, Role::kHysteresis); }
  // Raises a TPDO event for a mapped entry (CiA 301 §7.2.2.2).
  virtual void raise_pdo_event(Node& node, const OdEntry& e) { node.pdo().raise_event_for(e); }
  // Vendor supervision (status monitoring, counters, min/max capture), run
  // in every NMT state from the reset on, every supervision_period()
  // (0: the device has none).
  virtual void supervise(Node&, TimeUs) {}
  virtual TimeUs supervision_period() const { return 0; }
  // Delta / limit results of one check of channel `ch` (kEvent* bits). The
  // default raises a TPDO event for the mapped PV, field value and status on
  // kEventsRaising; vendors with their own event routing override it.
  virtual void on_channel_events(Node& node, std::size_t ch, unsigned events, TimeUs now);

  // Something a measurement depends on changed outside the OD hooks (a
  // vendor input chain, a hidden correction): the next measure() evaluates.
  void invalidate() { ++config_epoch_; }
  // A personality rewrote live objects (PV, field value, status) in place:
  // the next measure() renders them again even within the same instant.
  void live_objects_rewritten() {
    for (ChannelState& s : state_) s.rendered = false;
  }

  double param_value(const Node& node, const Param& p, int digits) const;
  void store_param(Node& node, const Param& p, double value, int digits);
  int digits(const Node& node, std::size_t ch) const;

 private:
  // The chain's parameters as the OD holds them, read again only after a
  // change of the configuration epoch (every hooked write bumps it).
  struct ChannelParams {
    std::uint32_t epoch = 0;
    int digits = 0;
    double offset = 0, span_start = 0, span_end = 0, delta = 0, upper = 0, lower = 0;
  };
  struct ChannelState {
    UnitChoice unit;
    ChannelParams params;
    double zero_si = 0.0;  // autozero correction (SI difference), added to the input
    double delta_ref = 0.0;
    bool have_ref = false;
    bool upper_armed = true;
    bool lower_armed = true;
    bool have_change_ref = false;
    std::uint64_t change_ref = 0;  // PV and field value bytes at the last change event
    std::vector<double> captured;  // logical values during a unit / digits write
    UnitChoice pending_unit;
    // measure() evaluates once per instant: TPDO sampling, SDO reads and
    // event checks at the same time share one evaluation.
    TimeUs measured_at = -1;
    std::uint32_t measured_epoch = 0;
    Measurement measured;
    bool rendered = false;  // the live objects hold `measured`
  };
  const UnitChoice* find_unit(const ChannelConfig& c, std::uint32_t code) const;
  UnitChoice resolve(const Node& node, const UnitChoice& u) const;
  void apply_filter(Node& node, std::size_t ch);
  void capture(const Node& node, std::size_t ch);
  void rerender(Node& node, std::size_t ch, const UnitScale* from, const UnitScale* to);
  void after_param_write(Node& node, std::size_t ch, const Param& p, const OdEntry& written);
  void autozero(Node& node, std::size_t ch, TimeUs now);
  std::uint32_t scan_event_channels(const Node& node, const ByteSet& types) const;
  void rescan_event_channels(const Node& node);
  bool changed(Node& node, std::size_t ch);
  bool check_events(Node& node, std::size_t ch, TimeUs now);
  TimeUs check_period(std::size_t ch) const;
  TimeUs check_events_due(Node& node, TimeUs now);
  const ChannelParams& params(const Node& node, std::size_t ch);
  Measurement evaluate(const Node& node, std::size_t ch, TimeUs now);
  std::uint8_t status_bits(std::size_t ch, const ChannelParams& p, const Measurement& m, std::uint8_t sensor_status) const;
  void fault_schedule_changed(Node& node, TimeUs now);
  void control_changed(Node& node, TimeUs now);

  std::shared_ptr<const Cia404Profile> profile_;
  std::unique_ptr<MeasurementSource> source_;
  SensorSource* sensor_;  // source_ when it is the node's physics, else null
  std::optional<double> override_si_[2];  // per physics::Channel
  IdentitySettings identity_;
  std::uint32_t node_index_;
  std::vector<ChannelState> state_;
  std::uint32_t config_epoch_ = 1;  // bumped by every change that can alter a measurement
  CommFaultDriver comm_faults_;
  std::uint32_t event_channels_ = 0;  // bit per channel mapped into an event TPDO
  std::uint32_t change_channels_ = 0;  // subset mapped into a change-event TPDO
  bool rescan_ = true;  // the event channels follow the TPDO configuration
  TimeUs next_check_ = 0;  // the next point of the event-check grid (anchored at reset)
  TimeUs next_supervision_ = 0;
};

// The Cia404Application behind a node's Application (null: none, e.g. a
// plain CiA 301 node). Pass the personality's own application, not a wrapper.
inline Cia404Application* as_cia404(Application* app) { return dynamic_cast<Cia404Application*>(app); }

}  // namespace cansim::personalities
