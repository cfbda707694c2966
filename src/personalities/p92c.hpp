// `danfoss-p92c` personality: Danfoss DST P92C CANopen pressure transmitter
// (profiles/p92c.yaml, docs/devices/p92c.md). The CiA 404 chain does the
// measurement; this adds what the manual describes beyond it: the serial
// number object 0x4E00, the bit-rate object's value set (0x4F00), the
// over/underflow counters 0x3000-0x3003 and the vendor EMCY codes.
#pragma once

#include <memory>

#include "personalities/sensor_application.hpp"

namespace cansim::personalities::p92c {

using Settings = model::P92cSettings;

class P92cApplication final : public VendorApplication<P92cApplication, Settings> {
 public:
  using VendorApplication::VendorApplication;

  void on_reset(Node& node, ResetKind kind, TimeUs now) override;
  TimeUs process(Node& node, TimeUs now) override;

  static const ObjectHooks<P92cApplication> kObjectHooks;  // the vendor objects' indications

 private:
  struct State {
    std::uint8_t last_status[2] = {};
  };
  static const ObjectHook<P92cApplication> kObjectRows[];

  SdoAbort check_bit_rate(Node& node, const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);
  void fill_serial(Node& node);
  void boot_checks(Node& node, ResetKind kind, TimeUs now);
  // Status supervision: counters, sensor-fault EMCYs.
  void supervise(Node& node, TimeUs now);

  State state_;
};

}  // namespace cansim::personalities::p92c
