// The typed settings of each personality, as a loader fills them from a
// profile's `vendor:` section (config/vendor_settings.cpp) and a personality
// takes them. Defaults are the manuals' behaviour. One alternative of
// DeviceSettings per personality; its index names the behaviour module.
#pragma once

#include <array>
#include <cstdint>
#include <variant>

#include "core/can_frame.hpp"

namespace cansim::model {

// Node identity settings shared by every personality (`vendor:` keys).
struct IdentitySettings {
  bool serial_per_node = false;  // 0x1018:04 = serial_base + node index
  std::uint32_t serial_base = 0;
};

// `generic`: the plain CiA 404 chain.
struct GenericSettings {};

// `honeywell-dps` (manual 50085804 Rev. B).
struct DpsSettings {
  bool span_overflow_emcy = true;    // EMCY 0x3201 while the PV is outside the span
  bool autozero_shifts_span = true;  // autozero moves 0x6148 / 0x6149 by the offset change
  TimeUs span_check_period_us = 1000;
};

// `danfoss-p92c`.
struct P92cSettings {
  std::uint8_t serial_part1 = 11;     // 0x4E00:01
  std::uint16_t serial_part3 = 5566;  // 0x4E00:03
  bool overload_counters = true;      // 0x3000-0x3003
  bool sensor_fault_emcy = true;      // 0xF011 / 0x4000 while a channel is invalid
  bool overload_emcy = false;         // ... and while it is overloaded
  bool boot_emcys = true;             // 0x6161 / 0x6363 / 0x6300 after the boot-up
  TimeUs monitor_period_us = 10000;
};

// `gems-9000` (manual 562293 Issue A).
struct GemsSettings {
  std::uint32_t pin = 0x00001234;        // 0x20FF value that unlocks 0x2800-0x2FFF
  bool direct_nvm = true;                // experienced_area_direct_nvm
  bool autostart_on_nmt_reset = false;   // 0x2813 = 0 also skips the boot-up at NMT resets
  bool boot_alias_2813 = false;          // 'boot' written to 0x2813 is a bootloader request
  bool manual_error_register = true;     // emcy_register_mode: manual (Fig. 28) | cia301
  TimeUs supervision_period_us = 10000;  // max / min, counters, EMCY checks
};

// `adz-smc` (manual EI-000038-DD v1826).
struct SmcSettings {
  std::uint16_t ad_fault_info = 0xC555;           // EMCY 0x5030 additional information
  bool reset_node_clears_error_register = false;  // §6.1.2: only power-off clears 0x1001
  bool analog_error_reaction = true;              // apply 0x1029:03 on a sensor error
  TimeUs stay_set_period_us = 10000;              // min/max capture and fault supervision
  double range_min[2] = {0.0, 218.15};            // SI range mapped to FV 0..20000 (from `sensor:`)
  double range_max[2] = {5.0e5, 398.15};
};

// `trafag-cmp`: the predefined TPDO mapping modes of 0x2100 and the start indication.
struct CmpSettings {
  static constexpr unsigned kMaxMode = 37;
  static constexpr unsigned kMaxEntries = 4;  // 0x1A0x subs 1..4
  struct MappingMode {
    bool defined = false;
    std::uint8_t count = 0;
    std::uint32_t entries[kMaxEntries] = {};  // checked: PDO-mappable objects of the profile, <= 64 bits
    std::uint8_t event_mask = 0;
  };
  std::array<MappingMode, kMaxMode + 1> modes;
  TimeUs start_indication_delay = 250000;
  std::uint8_t start_indication_node_id = 0;
  bool timer_repeats_beyond_limits = true;  // the core timer does not send type 254
};

// `cia401-analog-output`: the actuator stand-in (profiles/actuator-401.yaml):
// CiA 401 analogue outputs whose actual value follows the command.
struct AnalogOutputSettings {
  static constexpr unsigned kMaxChannels = 8;
  unsigned channels = 4;             // 0x6411:01.. and 0x6401:01..
  TimeUs response_time_us = 200000;  // first-order time constant of the actual value
};

using DeviceSettings = std::variant<GenericSettings, DpsSettings, P92cSettings, GemsSettings, SmcSettings, CmpSettings,
                                    AnalogOutputSettings>;

}  // namespace cansim::model
