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

namespace cansim::personalities::gems9000 {

using Settings = model::GemsSettings;  // the `vendor:` keys (config/vendor_settings.cpp)

class GemsApplication : public Cia404Application {
 public:
  GemsApplication(std::shared_ptr<const Cia404Profile> profile, std::unique_ptr<MeasurementSource> source,
                  const Settings& settings, IdentitySettings identity = {}, std::uint32_t node_index = 0);

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  void refresh(Node& node, const OdEntry& e, TimeUs now) override;
  SdoAbort check_write(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) override;
  void after_write(Node& node, const OdEntry& e, TimeUs now) override;

  bool unlocked() const { return unlocked_; }
  // True once 'boot' was written to the boot-load object (FLIP is out of scope).
  bool boot_requested() const { return boot_requested_; }

 protected:
  // Max / min, span counters, sensor and maths EMCYs.
  void supervise(Node& node, TimeUs now) override;
  TimeUs supervision_period() const override { return settings_.supervision_period_us; }

 private:
  enum class Span : std::uint8_t { kInside, kOver, kUnder };
  SdoAbort check_experienced(const OdEntry& e, std::span<const std::uint8_t> data);
  void apply_vendor_filter(Node& node, std::size_t ch);
  void supervise_channel(Node& node, std::size_t ch, TimeUs now);
  void track_peaks(Node& node, std::size_t ch, double pv, bool restart);
  void count_span(Node& node, std::size_t ch, double pv);
  void update_emcy(Node& node, std::uint16_t code, std::uint8_t reg, bool active, TimeUs now);
  void write_string(Node& node, const OdEntry& e, TimeUs now);

  Settings settings_;
  bool unlocked_ = false;
  bool boot_requested_ = false;
  bool peaks_valid_[2] = {};
  Span span_[2] = {};
  bool sensor_failed_[2] = {};
  bool math_error_ = false;
  TimeUs powered_at_ = 0;
};

std::unique_ptr<Application> make(const model::Profile& profile, const Settings& settings, const NodeContext& ctx);

}  // namespace cansim::personalities::gems9000
