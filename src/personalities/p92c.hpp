// `danfoss-p92c` personality: Danfoss DST P92C CANopen pressure transmitter
// (profiles/p92c.yaml, docs/devices/p92c.md). The CiA 404 chain does the
// measurement; this adds what the manual describes beyond it: the serial
// number object 0x4E00, the bit-rate object's value set (0x4F00), the
// over/underflow counters 0x3000-0x3003 and the vendor EMCY codes.
#pragma once

#include <memory>

#include "personalities/registry.hpp"
#include "personalities/sensor_application.hpp"

namespace cansim::personalities::p92c {

using Settings = model::P92cSettings;  // the `vendor:` keys (config/vendor_settings.cpp)

class P92cApplication final : public SensorApplication {
 public:
  P92cApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                  const Settings& settings, std::uint32_t node_index = 0);

  Cia404Chain& chain() override { return chain_; }
  const Cia404Chain& chain() const override { return chain_; }
  DevicePart& device() override { return device_; }

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  SdoAbort check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;
  std::unique_ptr<Application> snapshot() const override { return snapshot_of(*this); }
  void restore(const Application& snapshot) override { restore_from(*this, snapshot); }

 private:
  struct State {
    std::uint8_t last_status[2] = {};
    bool error[2] = {};  // the channel's EMCY reported
  };
  void fill_serial(Node& node);
  void boot_checks(Node& node, ResetKind kind, TimeUs now);
  // Status supervision: counters, sensor-fault EMCYs.
  void supervise(Node& node, TimeUs now);

  Cia404Chain chain_;
  DevicePart device_;
  Settings settings_;
  State state_;
};

std::unique_ptr<Application> make(const model::Profile& profile, const Settings& settings, const NodeContext& ctx);

}  // namespace cansim::personalities::p92c
