// `adz-smc` personality: ADZ NAGANO SMC pressure & temperature transducer
// (profiles/smc.yaml, docs/devices/smc.md, manual EI-000038-DD v1826).
//
// The CiA 404 chain does the live objects, decimal digits, integer views and
// delta / limit TPDO events. This adds the SMC measurement chain of manual §5:
//   FV (0x7100, 0..20000 counts) - input offset 0x3124/0x3125 -> filter
//   -> CiA 404 v1.2 linear scaling PV1 0x6121 / PV2 0x6123 (gain 0x6126,
//      offset 0x6127, write-order dependent) -> clamping 0x3200-0x3202 -> PV
// and the vendor objects: autozero 0x3126, stay-set indicators 0x3130/0x3131,
// time stamps 0x3140/0x3141, endianness 0x4000, node-ID 0x4001, device name
// 0x4022 (mirrored in 0x1008), serial 0x4030 (= 0x1018:04), the sensor-error
// EMCY 0x5030 with the latched error register and the 0x1029:03 reaction.
#pragma once

#include <memory>

#include "personalities/catalog.hpp"
#include "personalities/object_hooks.hpp"
#include "personalities/sensor_application.hpp"

namespace cansim::personalities::smc {

using Settings = model::SmcSettings;

class SmcApplication final : public VendorApplication<SmcApplication, Settings> {
 public:
  using VendorApplication::VendorApplication;

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  void refresh(Node& node, const OdEntry& e, TimeUs now) override;
  void after_write(Node& node, const OdEntry& e, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;

  static const ObjectHooks<SmcApplication> kObjectHooks;  // the vendor objects' indications
  static constexpr double kFieldSpan = 20000.0;           // FV2 - FV1 (0x7122 - 0x7120)

 private:
  struct MinMax {
    bool any = false;
    std::int32_t min = 0, max = 0;
    void add(std::int32_t v);
  };

  // The §5 scaling objects of one channel (sub 1 pressure, 2 temperature).
  struct ScalingObjects {
    const OdEntry *pv1 = nullptr, *pv2 = nullptr, *pv1_i32 = nullptr,
                  *pv2_i32 = nullptr;                                    // 0x6121 / 0x6123 / 0x9121 / 0x9123
    const OdEntry *gain = nullptr, *scale_offset = nullptr;              // 0x6126 / 0x6127
    const OdEntry *input_offset_i16 = nullptr, *input_offset = nullptr;  // 0x3124 / 0x3125
    const OdEntry *clamp_min = nullptr, *clamp_max = nullptr;            // 0x3201 / 0x3202
  };
  struct State {
    ScalingObjects objects[2] = {};
    LinearInput input[2];  // the §5 chain of each channel, as the chain measures through it
    MinMax uptime[2];
    MinMax lifetime[2];  // survives resets; kept by the application object
    bool latched_error = false;
    std::uint8_t latched_status[2] = {};  // 0x6150 bit 0 held like 0x1001
    TimeUs boot_time = 0;
  };

  static const ObjectHook<SmcApplication> kObjectRows[];

  void resolve_objects(const OdLayout& od);
  void load_chain(const Node& node);
  // ---- per-object indications (kObjectRows)
  void read_status_register(Node& node, const OdEntry& e, TimeUs now);
  void read_device_name(Node& node, const OdEntry& e, TimeUs now);
  void read_min_max(Node& node, const OdEntry& e, TimeUs now);
  void read_clock(Node& node, const OdEntry& e, TimeUs now);
  void read_clamp_switch(Node& node, const OdEntry& e, TimeUs now);
  void read_node_id(Node& node, const OdEntry& e, TimeUs now);
  void read_serial(Node& node, const OdEntry& e, TimeUs now);
  void read_status(Node& node, const OdEntry& e, TimeUs now);
  void read_in_byte_order(Node& node, const OdEntry& e, TimeUs now);
  SdoAbort check_time_cob_id(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_autozero(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_min_max_reset(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_clamp_switch(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_node_id(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_termination(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_device_name(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  void written_input_offset_i16(Node& node, const OdEntry& e, TimeUs now);
  void written_input_offset(Node& node, const OdEntry& e, TimeUs now);
  void written_autozero(Node& node, const OdEntry& e, TimeUs now);
  void written_min_max_reset(Node& node, const OdEntry& e, TimeUs now);
  void written_clamp_switch(Node& node, const OdEntry& e, TimeUs now);
  void written_node_id(Node& node, const OdEntry& e, TimeUs now);
  void written_device_name(Node& node, const OdEntry& e, TimeUs now);
  void written_serial(Node& node, const OdEntry& e, TimeUs now);
  void written_maintenance_time(Node& node, const OdEntry& e, TimeUs now);
  void written_pv1_or_pv2(Node& node, const OdEntry& e, TimeUs now);
  void written_scale_offset(Node& node, const OdEntry& e, TimeUs now);
  void written_gain(Node& node, const OdEntry& e, TimeUs now);
  void written_pv1_i32(Node& node, const OdEntry& e, TimeUs now);
  void written_pv2_i32(Node& node, const OdEntry& e, TimeUs now);
  void written_digits(Node& node, const OdEntry& e, TimeUs now);
  // ---- their parts
  static double pow10_digits(const Node& node, std::uint8_t sub);
  void write_scaling(Node& node, std::size_t ch, float pv1, float pv2);
  void fill_device_name_chars(Node& node);
  void refresh_device_name(Node& node);
  void change_node_id(Node& node, std::uint8_t sub, std::uint8_t id, TimeUs now);
  void supervise(Node& node, TimeUs now);
  void sensor_error(Node& node, TimeUs now);

  State state_;
};

// The objects and channels the behaviour needs (personalities/catalog.hpp).
Requirements requirements();

}  // namespace cansim::personalities::smc
