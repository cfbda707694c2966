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

#include "personalities/sensor_application.hpp"

namespace cansim::personalities::gems9000 {

using Settings = model::GemsSettings;

class GemsApplication final : public VendorApplication<GemsApplication, Settings> {
 public:
  using VendorApplication::VendorApplication;

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;

  static const ObjectHooks<GemsApplication> kObjectHooks;  // the vendor objects' indications

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
  static const ObjectHook<GemsApplication> kObjectRows[];

  // ---- per-object indications (kObjectRows)
  void read_seconds(Node& node, const OdEntry& e, TimeUs now);
  void read_peak(Node& node, const OdEntry& e, TimeUs now);
  void read_string(Node& node, const OdEntry& e, TimeUs now);
  void read_field_value(Node& node, const OdEntry& e, TimeUs now);
  SdoAbort check_pin(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_filter(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_user_unit(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_experienced(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_overflow_control(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_boot_load(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  void written_filter(Node& node, const OdEntry& e, TimeUs now);
  void written_peak_control(Node& node, const OdEntry& e, TimeUs now);
  void written_experienced(Node& node, const OdEntry& e, TimeUs now);
  void written_overflow_control(Node& node, const OdEntry& e, TimeUs now);
  void written_boot_load(Node& node, const OdEntry& e, TimeUs now);
  void written_network(Node& node, const OdEntry& e, TimeUs now);
  // ---- their parts
  std::size_t channel_of(const OdEntry& e) const;  // of a per-channel object's sub-index
  void apply_vendor_filter(Node& node, std::size_t ch);
  // Max / min, span counters, sensor and maths EMCYs.
  void supervise(Node& node, TimeUs now);
  void supervise_channel(Node& node, std::size_t ch, TimeUs now);
  void track_peaks(Node& node, std::size_t ch, double pv, bool restart);
  void count_span(Node& node, std::size_t ch, double pv);

  State state_;
};

}  // namespace cansim::personalities::gems9000
