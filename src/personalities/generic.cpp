#include "personalities/generic.hpp"

#include <algorithm>

namespace cansim::personalities::generic {

namespace {
constexpr std::uint8_t kDeviceProfileBit = 0x20;  // 0x1001 bit 5 (CiA 301 Table 48)
constexpr std::uint8_t kOverload = physics::kStatusPositiveOverload | physics::kStatusNegativeOverload;

// The error bits of a 0x6150 status the EMCYs signal (no range while not valid).
std::uint8_t error_bits(std::uint8_t status) {
  if (status & physics::kStatusInvalid) status &= std::uint8_t(~kOverload);
  return status & (physics::kStatusInvalid | kOverload);
}
}  // namespace

GenericApplication::GenericApplication(std::shared_ptr<const Cia404Profile> profile,
                                       std::unique_ptr<MeasurementSource> source, bool sensor_fault_emcy,
                                       std::uint32_t node_index)
    : VendorApplication(std::move(profile), std::move(source), {}, node_index) {
  state_.sensor_fault_emcy = sensor_fault_emcy;
}

void GenericApplication::on_reset(Node& node, ResetKind kind, TimeUs now) {
  SensorApplication::on_reset(node, kind, now);
  state_.reported.fill(0);  // the EMCY producer forgot them
  state_.resting = false;
}

TimeUs GenericApplication::process(Node& node, TimeUs now) {
  // Woken while the checks rest (a read, a write, a change): the next check
  // is at the next point of their grid.
  if (state_.resting) device_.resume_supervision(now, supervision_period());
  const TimeUs next = chain_.process(node, now);
  return std::min(next, device_.supervise(now, supervision_period(), [&] { return report_sensor_faults(node, now); }));
}

// A transmitter's diagnostic cycle: EMCYs within 100 ms of the fault, every
// tenth event check of generic-404 (same grid, from the reset), so the
// supervision costs no wake-up of its own.
TimeUs GenericApplication::supervision_period() const { return state_.sensor_fault_emcy ? ms(100) : 0; }

// Returns until when no channel's status can differ from what it reported
// while nothing reads the sensor (now: at the next check).
TimeUs GenericApplication::report_sensor_faults(Node& node, TimeUs now) {
  const std::size_t channels = std::min(chain_.profile().channels.size(), state_.reported.size());
  TimeUs quiet = kNever;
  for (std::size_t ch = 0; ch < channels; ++ch) {
    std::uint8_t sure = 0;
    TimeUs until = chain_.status_steady_until(node, ch, now, sure);
    if (until <= now || error_bits(sure) != state_.reported[ch]) {
      // The range of a value that is not valid means nothing (an open sensor reads the rail).
      const std::uint8_t status = error_bits(chain_.measure(node, ch, now).status);
      report(node, ch, kEmcySensorFault, physics::kStatusInvalid, status, now);
      report(node, ch, kEmcyRangeExceeded, kOverload, status, now);
      until = chain_.status_steady_until(node, ch, now, sure);
      if (error_bits(sure) != state_.reported[ch]) until = now;
    }
    quiet = std::min(quiet, until);
  }
  state_.resting = quiet > now;
  if (state_.resting) chain_.wake_app_on_read();
  return quiet;
}

// An EMCY when channel `ch` enters the condition (`bits` of 0x6150); the
// code clears when no channel is in it any more.
void GenericApplication::report(Node& node, std::size_t ch, std::uint16_t code, std::uint8_t bits, std::uint8_t status,
                                TimeUs now) {
  std::uint8_t& reported = state_.reported[ch];
  const bool was = reported & bits;
  const bool is = status & bits;
  reported = std::uint8_t((reported & ~bits) | (status & bits));
  if (is && !was) {
    const std::uint8_t mfr[5] = {chain_.profile().channels[ch].sub, std::uint8_t(status & bits)};
    node.emcy().raise(code, kDeviceProfileBit, mfr, now);
  } else if (was && !is) {
    for (std::uint8_t r : state_.reported)
      if (r & bits) return;
    node.emcy().clear(code, now);
  }
}

}  // namespace cansim::personalities::generic
