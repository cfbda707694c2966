// `danfoss-p92c` personality: Danfoss DST P92C CANopen pressure transmitter
// (profiles/p92c.yaml, docs/devices/p92c.md). The CiA 404 chain does the
// measurement; this adds what the manual describes beyond it: the serial
// number object 0x4E00, the bit-rate object's value set (0x4F00), the
// over/underflow counters 0x3000-0x3003 and the vendor EMCY codes.
#pragma once

#include <memory>

#include "personalities/registry.hpp"

namespace cansim::personalities::p92c {

using Settings = model::P92cSettings;  // the `vendor:` keys (config/vendor_settings.cpp)

class P92cApplication : public Cia404Application {
 public:
  P92cApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                  const Settings& settings, IdentitySettings identity = {}, std::uint32_t node_index = 0);

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  SdoAbort check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) override;

 protected:
  // Status supervision: counters, sensor-fault EMCYs.
  void supervise(Node& node, TimeUs now) override;
  TimeUs supervision_period() const override { return settings_.monitor_period_us; }

 private:
  void fill_serial(Node& node);
  void boot_checks(Node& node, ResetKind kind, TimeUs now);
  void count_edge(Node& node, std::uint16_t counter);

  Settings settings_;
  std::uint8_t last_status_[2] = {};
  bool error_[2] = {};
};

std::unique_ptr<Application> make(const model::Profile& profile, const Settings& settings, const NodeContext& ctx);

}  // namespace cansim::personalities::p92c
