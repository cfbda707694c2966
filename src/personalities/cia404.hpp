// The CiA 404 measurement chain, shared by every sensor personality.
//
// One chain per analogue-input channel (channel n = sub-index n of the 0x61xx
// objects). A channel's logical values (PV, offset, span, limits, ...) are each
// seen through up to four OD views: REAL32 (0x61xx) and the INTEGER16
// (0x71xx) / INTEGER24 (0x81xx) / INTEGER32 (0x91xx) twins, whose integers are value x 10^digits
// (0x6132). Which objects exist, their types, the accepted units and which
// objects follow a unit change are profile data; a device personality holds
// a Cia404Chain (a plain value) and changes what its manual says differs as
// data (a linear input stage, a limit hysteresis, its event routing).
//
//   source (physics::Sensor, SI) -> unit 0x6131 -> + offset 0x6124 -> PV 0x6130 / 0x7130 / 0x9130
//   raw ADC counts -> FV 0x6100 / 0x7100 / 0x9100;  span 0x6148/0x6149 -> status 0x6150
//   delta 0x6133, limits 0x6134/0x6135 with hysteresis 0x6136 -> TPDO events (type 254/255)
//
// Files: cia404.cpp the chain and its events, cia404_control.cpp its control
// API side, sensor_source.* the physics adapter; the chain's profile data is
// model/cia404_profile.hpp. device_part.* has what a sensor device adds
// (faults, supervision), sensor_application.hpp how a personality holds both.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/node.hpp"
#include "core/node_options.hpp"
#include "model/cia404_profile.hpp"
#include "model/units.hpp"
#include "personalities/sensor_source.hpp"

namespace cansim::personalities {

// The chain's profile data (src/model/cia404_profile.hpp).
using model::ChannelConfig;
using model::Cia404Profile;
using model::Cia404Settings;
using model::DigitsOnUnitChange;
using model::kRoleCount;
using model::Param;
using model::Role;
using model::UnitChoice;
using model::UnitScale;

// What one event check of a channel found (the events an EventRoute gets).
enum : unsigned {
  kEventChange = 0x01,     // the mapped value changed (change_event_tpdo_types)
  kEventDelta = 0x02,      // |PV - reference| > delta
  kEventUpperUp = 0x04,    // PV rose above the upper limit
  kEventUpperDown = 0x08,  // PV fell back to upper limit - hysteresis (re-armed)
  kEventLowerDown = 0x10,  // PV fell below the lower limit
  kEventLowerUp = 0x20,    // PV rose back to lower limit + hysteresis (re-armed)
  kEventsRaising = kEventChange | kEventDelta | kEventUpperUp | kEventLowerDown,
};

// A non-owning reference to a callable `void(std::size_t channel, unsigned
// events)`: how a personality routes the events of one check (the chain's
// default raises the CiA 404 TPDO events).
class EventRoute {
 public:
  EventRoute() = default;
  template <class F>
  requires(!std::is_same_v<std::remove_cv_t<F>, EventRoute>)
      EventRoute(F& f)  // NOLINT: implicit, like std::function_ref
      : obj_(&f), call_([](void* o, std::size_t ch, unsigned events) { (*static_cast<F*>(o))(ch, events); }) {}
  explicit operator bool() const { return call_ != nullptr; }
  void operator()(std::size_t ch, unsigned events) const { call_(obj_, ch, events); }

 private:
  void* obj_ = nullptr;
  void (*call_)(void*, std::size_t, unsigned) = nullptr;
};

// CiA 404 v1.2 linear input scaling (field value -> PV through PV1 / PV2,
// 0x6120-0x6127) with an input offset and an output clamp, in float as the
// devices compute it (the SMC's §5 chain). The field value spans
// 0..field_span over the sensor's SI range si_min..si_max.
struct LinearInput {
  double si_min = 0, si_max = 1, field_span = 1;
  float gain = 1.0f, pv1 = 0.0f;   // 0x6126 / 0x6127
  float offset = 0.0f;             // input offset (field value counts)
  float cmin = 0.0f, cmax = 0.0f;  // output clamp
  double field_value(double si) const { return (si - si_min) / (si_max - si_min) * field_span; }
  float scale(double fv) const;  // PV of a field value: offset, scaling, clamping
  bool operator==(const LinearInput&) const = default;
};

// The measurement source of a chain as a value: a copy clones the source
// (MeasurementSource::snapshot), an assignment restores the copy's state
// into this one (no allocation), so a chain is copied and assigned as a
// plain value. A source without snapshots makes an empty copy (copyable() false).
class SourceSlot {
 public:
  explicit SourceSlot(std::unique_ptr<MeasurementSource> source);
  SourceSlot(const SourceSlot& other);
  SourceSlot& operator=(const SourceSlot& other);
  MeasurementSource& operator*() const { return *source_; }
  MeasurementSource* operator->() const { return source_.get(); }
  bool copyable() const { return source_ != nullptr; }
  SensorSource* sensor() const { return sensor_; }  // the node's physics, else null

 private:
  std::unique_ptr<MeasurementSource> source_;
  SensorSource* sensor_;
};

// The CiA 404 measurement chain of one node: channel states, parameters as
// the OD holds them, events, overrides and the measurement source. A value
// type (copies are snapshots) with methods taking the node; a personality
// holds one and calls it from its Application hooks (sensor_application.hpp).
class Cia404Chain {
 public:
  Cia404Chain(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source);
  bool copyable() const { return source_.copyable(); }

  // ---- what the Application hooks of a CiA 404 sensor do
  void on_reset(Node& node, ResetKind kind, TimeUs now);
  void on_nmt_state(Node& node, TimeUs now);
  void on_pdo_config(Node& node, TimeUs now);
  void refresh(Node& node, const OdEntry& e, TimeUs now);
  SdoAbort check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  void after_write(Node& node, const OdEntry& e, TimeUs now);
  // Delta / limit / change checks of the channels mapped into event TPDOs,
  // on the device's check grid; each check's kEvent* bits go to `route`
  // (default: raise_events). Returns when the next check is due.
  TimeUs process(Node& node, TimeUs now, EventRoute route = {});
  // CiA 404's routing: a TPDO event for the mapped PV, field value and
  // status on kEventsRaising (CiA 301 §7.2.2.2).
  void raise_events(Node& node, std::size_t ch, unsigned events);

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
  // Until when channel `ch`'s status (0x6150) is sure to be `status` at a
  // measurement, without measuring (now: nothing is sure). Sure until the
  // next read of the source, change of a parameter, of the model or of the
  // fault schedule: wake_app_on_read() tells of the first.
  TimeUs status_steady_until(const Node& node, std::size_t ch, TimeUs now, std::uint8_t& status);
  // The next measurement (or look at the true value) wakes the application
  // (Node::wake_app), once.
  void wake_app_on_read() { wake_on_read_ = true; }
  // Changes with every change a measurement depends on (parameters, model,
  // faults, overrides).
  std::uint32_t config_epoch() const { return config_epoch_; }
  // A logical value in the channel's current unit (0 when the object is absent).
  double get(const Node& node, std::size_t ch, Role role) const;
  void set(Node& node, std::size_t ch, Role role, double value);
  const UnitScale& unit(std::size_t ch) const { return state_[ch].unit.scale; }
  // What a raw value of entry `e` means: a valued object of a channel (PV,
  // offset, span, limits) is in the channel's current unit, its integer views
  // x 10^digits (0x6132); anything else has no unit (scale 1, unit ""). On a
  // channel whose PV is in counts (count_scaling), the raw value is counts
  // and the engineering value is derived with the device's own scaling.
  struct EntryScale {
    double scale = 1.0;  // engineering value = raw value x scale + offset
    double offset = 0.0;
    std::string_view unit;  // as the control API names it ("bar", "degC"); "" for none
    bool counts = false;    // the device's value is raw x count_scale counts, not in `unit`
    double count_scale = 1.0;
  };
  EntryScale entry_scale(const Node& node, const OdEntry& e) const;
  // How channel `ch`'s PV relates to its 0x6131 unit: nullopt when the PV is
  // in that unit (CiA 404). A vendor input chain (set_linear_input) whose
  // scaling maps the field value anywhere else makes the PV counts (the SMC's
  // default, manual §6.2.3: 0x6131 is informational): engineering value =
  // PV x factor + offset, in the unit (NaN when the scaling has no inverse).
  struct CountScaling {
    double factor = 1.0, offset = 0.0;
  };
  std::optional<CountScaling> count_scaling(std::size_t ch) const;
  const Cia404Profile& profile() const { return *profile_; }
  MeasurementSource& source() { return *source_; }
  const MeasurementSource& source() const { return *source_; }
  physics::FaultSet* fault_set() { return source_->fault_set(); }
  const physics::FaultSet* fault_set() const { return source_->fault_set(); }
  int digits(const Node& node, std::size_t ch) const;
  double param_value(const Node& node, const Param& p, int digits) const;
  void store_param(Node& node, const Param& p, double value, int digits);

  // ---- what a device changes in the chain (as data: a copy keeps it)
  // Channel `ch` measures through `input` instead of the unit conversion
  // (nullopt: back to it); a changed input invalidates the measurement.
  void set_linear_input(std::size_t ch, const std::optional<LinearInput>& input);
  // The limit hysteresis of channel `ch` (nullopt: CiA 404 0x6136).
  void set_limit_hysteresis(std::size_t ch, std::optional<double> hysteresis) { state_[ch].hysteresis = hysteresis; }
  // Something a measurement depends on changed outside the OD hooks (a
  // vendor input chain, a hidden correction, the fault schedule): the next
  // measure() evaluates.
  void invalidate() { ++config_epoch_; }
  // A personality rewrote live objects (PV, field value, status) in place:
  // the next measure() renders them again even within the same instant.
  void live_objects_rewritten() {
    for (ChannelState& s : state_) s.rendered = false;
  }

  // ---- runtime control: the chain's side of the control API
  // (docs/control-api.md, MeasurementControl). A physics channel is
  // served by the first chain channel with that source. Each change acts at
  // `now` and wakes the node, so PV reads, event TPDOs and change events
  // follow as for a sensor change.
  std::optional<std::size_t> chain_channel(physics::Channel ch) const;
  bool has_channel(physics::Channel ch) const { return chain_channel(ch).has_value(); }
  // The source has a process model (false: a test's fake source; then the
  // process methods below return false and change nothing).
  bool has_process() const { return source_.sensor() != nullptr; }
  // The channel's process model from `now` on (the terms' time 0 is `now`).
  // Throws std::invalid_argument, changing nothing, on invalid terms.
  bool set_process(Node& node, physics::Channel ch, const std::vector<physics::TermSpec>& terms, TimeUs now);
  bool restore_process(Node& node, physics::Channel ch, TimeUs now);  // back to the profile's model
  // The process model's value, Pa / K (NaN without a process model).
  double true_value_si(physics::Channel ch, TimeUs now);

  struct ChannelView {
    double true_value = std::numeric_limits<double>::quiet_NaN();  // in `unit`
    double reported = std::numeric_limits<double>::quiet_NaN();    // what the PV the node answers means, in `unit`
    double counts = std::numeric_limits<double>::quiet_NaN();  // that PV when it is counts (count_scaling), else NaN
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
    bool rendered = false;             // the live objects hold `measured`
    std::optional<LinearInput> input;  // set_linear_input
    std::optional<double> hysteresis;  // set_limit_hysteresis
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
  unsigned check_limits(std::size_t ch, const ChannelParams& p, double pv, double hysteresis);
  bool check_events(Node& node, std::size_t ch, TimeUs now, EventRoute route);
  TimeUs check_period(std::size_t ch) const;
  double limit_hysteresis(const Node& node, std::size_t ch) const;
  double input_value(std::size_t ch, const MeasurementSource::Sample& s) const;
  const ChannelParams& params(const Node& node, std::size_t ch);
  Measurement evaluate(const Node& node, std::size_t ch, TimeUs now);
  void note_read(Node& node, TimeUs now);
  std::uint8_t status_bits(std::size_t ch, const ChannelParams& p, const Measurement& m,
                           std::uint8_t sensor_status) const;
  void control_changed(Node& node, TimeUs now);

  std::shared_ptr<const Cia404Profile> profile_;
  SourceSlot source_;
  std::optional<double> override_si_[2];  // per physics::Channel
  std::vector<ChannelState> state_;
  std::uint32_t config_epoch_ = 1;  // bumped by every change that can alter a measurement
  bool meaning_changed_ = false;    // a linear input changed what the PV means: observers hear it at the next measure()
  std::uint32_t event_channels_ = 0;   // bit per channel mapped into an event TPDO
  std::uint32_t change_channels_ = 0;  // subset mapped into a change-event TPDO
  bool rescan_ = true;                 // the event channels follow the TPDO configuration
  TimeUs next_check_ = 0;              // the next point of the event-check grid (anchored at reset)
  bool wake_on_read_ = false;
};

}  // namespace cansim::personalities
