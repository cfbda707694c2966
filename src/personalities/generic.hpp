// `generic` personality: the plain CiA 404 chain for the channels of the
// profile (generic-404.yaml: ch1 pressure in bar, ch2 temperature in degC),
// measuring the profile's physics, and the reference node's sensor faults
// on the wire (README "Profiles"): a channel whose 0x6150 says "not valid"
// (open, short, sensor error) raises EMCY kSensorFault, an overloaded one
// kRangeExceeded, each with 0x1001 bit 5 (device profile specific) and the
// channel's sub-index and the condition's 0x6150 bits in manufacturer bytes
// 0-1 (no range EMCY while the value is not valid); the error reset follows
// when no channel has the condition any more. Checked every 100 ms from the
// reset on, in every NMT state.
#pragma once

#include <array>
#include <memory>

#include "personalities/registry.hpp"
#include "personalities/sensor_application.hpp"

namespace cansim::personalities::generic {

constexpr std::uint16_t kEmcySensorFault = 0x5030;    // CiA 301 class 5xxx: device hardware
constexpr std::uint16_t kEmcyRangeExceeded = 0xF001;  // CiA 301 class Fxxx: additional functions

class GenericApplication final : public SensorApplication {
 public:
  // sensor_fault_emcy: false leaves the chain alone (a test of the chain).
  GenericApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                     bool sensor_fault_emcy = true, std::uint32_t node_index = 0);

  Cia404Chain& chain() override { return chain_; }
  const Cia404Chain& chain() const override { return chain_; }
  DevicePart& device() override { return device_; }

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;
  std::unique_ptr<Application> snapshot() const override { return snapshot_of(*this); }
  void restore(const Application& snapshot) override { restore_from(*this, snapshot); }

 private:
  struct State {
    bool sensor_fault_emcy = true;
    std::array<std::uint8_t, 32> reported{};  // per channel: the 0x6150 error bits an EMCY signalled
  };
  TimeUs supervision_period() const;
  void report_sensor_faults(Node& node, TimeUs now);
  void report(Node& node, std::size_t ch, std::uint16_t code, std::uint8_t bits, std::uint8_t status, TimeUs now);

  Cia404Chain chain_;
  DevicePart device_;
  State state_;
};

std::unique_ptr<Application> make(const model::Profile& profile, const NodeContext& ctx);

}  // namespace cansim::personalities::generic
