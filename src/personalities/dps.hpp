// `honeywell-dps` personality: Honeywell Model DPS digital pressure sensor
// (manual 50085804 Rev. B). The CiA 404 chain does units, offset, autozero,
// span and the type-0 change events; this adds what the manual adds on top:
// span overflow / underflow counters 0x2004 / 0x2005 with EMCY 0x3201,
// sensor failure EMCY 0x2201, EEPROM EMCY 0x5000, 0x200E = serial number,
// and the autozero that shifts span start / end too (manual §10.5).
// Device switches (vendor section): docs/devices/dps.md.
#pragma once

#include <memory>

#include "personalities/catalog.hpp"
#include "personalities/sensor_application.hpp"

namespace cansim::personalities::dps {

using Settings = model::DpsSettings;

class DpsApplication final : public VendorApplication<DpsApplication, Settings> {
 public:
  using VendorApplication::VendorApplication;

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  void after_write(Node& node, const OdEntry& e, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;

 private:
  struct State {
    const OdEntry* overflows = nullptr;   // 0x2004
    const OdEntry* underflows = nullptr;  // 0x2005
    SpanMonitor span;
  };
  void check_span(Node& node, TimeUs now);

  State state_;
};

// The objects and channels the behaviour needs (personalities/catalog.hpp).
Requirements requirements();

}  // namespace cansim::personalities::dps
