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

namespace cansim::personalities::dps {

using Settings = model::DpsSettings;  // the `vendor:` keys (config/vendor_settings.cpp)

class DpsApplication : public Cia404Application {
 public:
  DpsApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                 const Settings& settings, IdentitySettings identity = {}, std::uint32_t node_index = 0);

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  void after_write(Node& node, const OdEntry& e, TimeUs now) override;

 protected:
  // Span over/underflow: EMCY 0x3201 and the counters 0x2004 / 0x2005.
  void supervise(Node& node, TimeUs now) override { check_span(node, now); }
  TimeUs supervision_period() const override { return settings_.span_check_period_us; }

 private:
  enum class Span : std::uint8_t { kInside, kOver, kUnder };
  void check_span(Node& node, TimeUs now);
  void count(Node& node, const OdEntry* counter);

  Settings settings_;
  const OdEntry* serial_ = nullptr;     // 0x1018:04
  const OdEntry* serial_copy_ = nullptr;  // 0x200E
  const OdEntry* overflows_ = nullptr;  // 0x2004
  const OdEntry* underflows_ = nullptr;  // 0x2005
  Span span_ = Span::kInside;
  bool sensor_failed_ = false;
};

// The objects and channels the behaviour needs (personalities/catalog.hpp).
Requirements requirements();

std::unique_ptr<Application> make(const model::Profile& profile, const Settings& settings, const NodeContext& ctx);

}  // namespace cansim::personalities::dps
