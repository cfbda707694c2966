// `trafag-cmp` personality: Trafag CMP 8270/8826 miniature pressure
// transmitter (manual V2.0, profiles/cmp.yaml, docs/devices/cmp.md).
//
// On top of the CiA 404 chain: predefined mapping modes (0x2100, mirrored
// read-only into 0x1A0x), a per-PDO EventMask routing delta / threshold events
// to TPDO types 0 and 254, special messages chosen by the last limit event,
// the type-254 timer that repeats only beyond a threshold, the ms counter of
// mapping mode 37, Auto-Start with AUTO-PRE-OPERATIONAL fault handling, the
// NMT start indication 250 ms after OPERATIONAL, the 0x2001 baud-rate object
// and the permanent self-test EMCYs.
#pragma once

#include <array>
#include <cstdint>

#include "personalities/sensor_application.hpp"

namespace cansim::personalities::cmp {

using Settings = model::CmpSettings;

class CmpApplication final : public VendorApplication<CmpApplication, Settings> {
 public:
  using VendorApplication::VendorApplication;

  static constexpr unsigned kPdoCount = 4;

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  void on_nmt_state(Node& node, NmtState state, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;

  static const ObjectHooks<CmpApplication> kObjectHooks;  // the vendor objects' indications

 private:
  struct State {
    std::array<std::uint8_t, 2> limit_state{};  // per channel: the last LimitEventType
    std::array<TimeUs, kPdoCount> repeat_due{kNever, kNever, kNever, kNever};
    TimeUs indication_due = kNever;
    bool auto_start = false;
    bool auto_resume = false;
  };

  static const ObjectHook<CmpApplication> kObjectRows[];

  // ---- per-object indications (kObjectRows)
  void read_ms_counter(Node& node, const OdEntry& e, TimeUs now);
  void read_actual_message(Node& node, const OdEntry& e, TimeUs now);
  void read_last_node_error(Node& node, const OdEntry& e, TimeUs now);
  SdoAbort check_mapping_mode(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  SdoAbort check_baud_rate(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  void written_mapping_mode(Node& node, const OdEntry& e, TimeUs now);
  void written_baud_rate(Node& node, const OdEntry& e, TimeUs now);
  // ---- their parts and the rest
  void route_events(Node& node, std::size_t ch, unsigned events, TimeUs now);
  void apply_baud_rate(Node& node);
  void apply_mapping_mode(Node& node, unsigned n, bool reset_mask, TimeUs now);
  void render_special_message(Node& node, const OdEntry& e, unsigned ch);
  TimeUs repeat_beyond_limits(Node& node, TimeUs now);
  bool beyond_limits(std::uint64_t mask) const;
  void self_test_at_start_up(Node& node, TimeUs now);
  void raise(Node& node, std::uint16_t code, std::uint16_t sub, TimeUs now);
  void check_faults(Node& node, TimeUs now);

  State state_;
};

}  // namespace cansim::personalities::cmp
