// `honeywell-dps` personality: Honeywell Model DPS digital pressure sensor
// (manual 50085804 Rev. B). The CiA 404 chain does units, offset, autozero,
// span and the type-0 change events; this adds what the manual adds on top:
// span overflow / underflow counters 0x2004 / 0x2005 with EMCY 0x3201,
// sensor failure EMCY 0x2201, EEPROM EMCY 0x5000, 0x200E = serial number,
// and the autozero that shifts span start / end too (manual §10.5).
// Device switches (vendor section): docs/devices/dps.md.
#pragma once

#include <memory>

#include "personalities/registry.hpp"
#include "personalities/sensor_application.hpp"

namespace cansim::personalities::dps {

using Settings = model::DpsSettings;  // the `vendor:` keys (config/vendor_settings.cpp)

class DpsApplication final : public SensorApplication {
 public:
  DpsApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                 const Settings& settings, std::uint32_t node_index = 0);

  Cia404Chain& chain() override { return chain_; }
  const Cia404Chain& chain() const override { return chain_; }
  DevicePart& device() override { return device_; }

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  void after_write(Node& node, const OdEntry& e, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;
  std::unique_ptr<Application> snapshot() const override { return snapshot_of(*this); }
  void restore(const Application& snapshot) override { restore_from(*this, snapshot); }

 private:
  struct State {
    const OdEntry* overflows = nullptr;   // 0x2004
    const OdEntry* underflows = nullptr;  // 0x2005
    SpanMonitor span;
    bool sensor_failed = false;           // EMCY 0x2201 reported
  };
  void check_span(Node& node, TimeUs now);

  Cia404Chain chain_;
  DevicePart device_;
  Settings settings_;
  State state_;
};

// The objects and channels the behaviour needs (personalities/catalog.hpp).
Requirements requirements();

std::unique_ptr<Application> make(const model::Profile& profile, const Settings& settings, const NodeContext& ctx);

}  // namespace cansim::personalities::dps
