// `generic` personality: the plain CiA 404 chain for the channels of the
// profile (generic-404.yaml: ch1 pressure in bar, ch2 temperature in degC),
// measuring the profile's physics, and the reference node's sensor faults
// on the wire (docs/profiles.md): a channel whose 0x6150 says "not valid"
// (open, short, sensor error) raises EMCY kSensorFault, an overloaded one
// kRangeExceeded, each with 0x1001 bit 5 (device profile specific) and the
// channel's sub-index and the condition's 0x6150 bits in manufacturer bytes
// 0-1 (no range EMCY while the value is not valid); the error reset follows
// when no channel has the condition any more. Checked every 100 ms from the
// reset on, in every NMT state; a check skips a channel whose status is sure
// to be what it reported (Cia404Chain::status_steady_until), and while every
// channel is, the checks rest until one may not be (the sensor is read, a
// parameter, the model or the fault schedule changes): an idle node does not
// evaluate its sensor.
#pragma once

#include <array>
#include <memory>

#include "personalities/sensor_application.hpp"

namespace cansim::personalities::generic {

constexpr std::uint16_t kEmcySensorFault = 0x5030;    // CiA 301 class 5xxx: device hardware
constexpr std::uint16_t kEmcyRangeExceeded = 0xF001;  // CiA 301 class Fxxx: additional functions

class GenericApplication final : public VendorApplication<GenericApplication, model::GenericSettings> {
 public:
  GenericApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                     const model::GenericSettings& = {}, std::uint32_t node_index = 0)
      : GenericApplication(std::move(profile), std::move(source), true, node_index) {}
  // sensor_fault_emcy: false leaves the chain alone (a test of the chain).
  GenericApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                     bool sensor_fault_emcy, std::uint32_t node_index = 0);

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;

 private:
  struct State {
    bool sensor_fault_emcy = true;
    std::array<std::uint8_t, 32> reported{};  // per channel: the 0x6150 error bits an EMCY signalled
    bool resting = false;                     // the checks skip grid points: nothing could change
  };
  TimeUs supervision_period() const;
  TimeUs report_sensor_faults(Node& node, TimeUs now);
  void report(Node& node, std::size_t ch, std::uint16_t code, std::uint8_t bits, std::uint8_t status, TimeUs now);

  State state_;
};

}  // namespace cansim::personalities::generic
