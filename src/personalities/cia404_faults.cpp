// The CiA 404 chain's fault glue: the node's fault schedule (measurement
// faults in the sensor, communication faults in the CommFaultDriver), armed
// from the profile at boot and by the control API at run time.
#include "personalities/cia404.hpp"

namespace cansim::personalities {

namespace {
constexpr std::uint8_t kDeviceProfileBit = 0x20;  // 0x1001 bit 5 (CiA 301 Table 48)
constexpr std::uint8_t kOverload = physics::kStatusPositiveOverload | physics::kStatusNegativeOverload;
}  // namespace

TimeUs Cia404Application::supervision_period() const {
  if (!sensor_fault_emcy_) return 0;
  const TimeUs p = profile_->settings.event_check_period_us;
  return p > 0 ? p : 10000;
}

void Cia404Application::report_sensor_faults(Node& node, TimeUs now) {
  if (!sensor_fault_emcy_) return;
  for (std::size_t ch = 0; ch < state_.size(); ++ch) {
    std::uint8_t status = measure(node, ch, now).status;
    // The range of a value that is not valid means nothing (an open sensor reads the rail).
    if (status & physics::kStatusInvalid) status &= std::uint8_t(~kOverload);
    report_condition(node, ch, kEmcySensorFault, physics::kStatusInvalid, status, now);
    report_condition(node, ch, kEmcyRangeExceeded, kOverload, status, now);
  }
}

// An EMCY when channel `ch` enters the condition (`bits` of 0x6150); the
// code clears when no channel is in it any more.
void Cia404Application::report_condition(Node& node, std::size_t ch, std::uint16_t code, std::uint8_t bits,
                                         std::uint8_t status, TimeUs now) {
  std::uint8_t& reported = state_[ch].emcy_status;
  const bool was = reported & bits;
  const bool is = status & bits;
  reported = std::uint8_t((reported & ~bits) | (status & bits));
  if (is && !was) {
    const std::uint8_t mfr[5] = {profile_->channels[ch].sub, std::uint8_t(status & bits)};
    node.emcy().raise(code, kDeviceProfileBit, mfr, now);
  } else if (was && !is) {
    for (const ChannelState& st : state_)
      if (st.emcy_status & bits) return;
    node.emcy().clear(code, now);
  }
}

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
