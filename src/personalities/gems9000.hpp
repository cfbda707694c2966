// `gems-9000` personality: Gems Sensors CANbus Pressure Transducer Series 9000
// (manual 562293 Issue A; profiles/gems9000.yaml, docs/devices/gems9000.md).
// The CiA 404 chain does units (with the 0x2032 user unit), digits, offset,
// the hidden autozero correction and the INT16 / REAL32 views; this adds the
// vendor objects: PIN-protected experienced user area 0x2800-0x2FFF stored
// straight to NVM, 0x5130 ASCII strings, max / min 0x4130 / 0x4131 with the
// 0x2031 reset, span overflow / underflow counters 0x2006-0x2009 with 0x2803
// 'zero', the 0x2030 filter, 0x2813 power-on auto-start and the Fig. 28 EMCYs.
#pragma once

#include <memory>

#include "personalities/registry.hpp"
#include "personalities/sensor_application.hpp"

namespace cansim::personalities::gems9000 {

using Settings = model::GemsSettings;  // the `vendor:` keys (config/vendor_settings.cpp)

class GemsApplication final : public SensorApplication {
 public:
  GemsApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                  const Settings& settings, std::uint32_t node_index = 0);

  Cia404Chain& chain() override { return chain_; }
  const Cia404Chain& chain() const override { return chain_; }
  DevicePart& device() override { return device_; }

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  void refresh(Node& node, const OdEntry& e, TimeUs now) override;
  SdoAbort check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) override;
  void after_write(Node& node, const OdEntry& e, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;
  std::unique_ptr<Application> snapshot() const override { return snapshot_of(*this); }
  void restore(const Application& snapshot) override { restore_from(*this, snapshot); }

  bool unlocked() const { return state_.unlocked; }
  // True once 'boot' was written to the boot-load object (FLIP is out of scope).
  bool boot_requested() const { return state_.boot_requested; }

 private:
  struct State {
    bool unlocked = false;
    bool boot_requested = false;
    bool peaks_valid[2] = {};
    SpanMonitor span[2];
    bool sensor_failed[2] = {};
    bool math_error = false;
    TimeUs powered_at = 0;
  };
  SdoAbort check_experienced(const OdEntry& e, std::span<const std::uint8_t> data);
  void apply_vendor_filter(Node& node, std::size_t ch);
  // Max / min, span counters, sensor and maths EMCYs.
  void supervise(Node& node, TimeUs now);
  void supervise_channel(Node& node, std::size_t ch, TimeUs now);
  void track_peaks(Node& node, std::size_t ch, double pv, bool restart);
  void count_span(Node& node, std::size_t ch, double pv);
  void update_emcy(Node& node, std::uint16_t code, std::uint8_t reg, bool active, TimeUs now);
  void write_string(Node& node, const OdEntry& e, TimeUs now);

  Cia404Chain chain_;
  DevicePart device_;
  Settings settings_;
  State state_;
};

std::unique_ptr<Application> make(const model::Profile& profile, const Settings& settings, const NodeContext& ctx);

}  // namespace cansim::personalities::gems9000
