// Shared set-up for the PDO engine tests: one node (ID 5) with two TPDOs, one
// RPDO and a few application objects, on a SimBus with a fake clock.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "config/profile.hpp"
#include "support/sim.hpp"

namespace cansim::pdo_test {

using test::F;
using test::Sent;

// TPDO1 0x185: type 255, maps 0x2000 (U32) + 0x2001 (U16) = 6 bytes.
// TPDO2 0x285: type 1, maps 0x2003 (U8, ro).
// RPDO1 0x205: type 255, maps 0x2000 (U32) + 0x2001 (U16).
inline std::string pdo_profile(const std::string& options) {
  return R"(
name: pdo-test
node_id: 5
options: )" +
         options + R"(
objects:
  - {index: 0x1000, type: UNSIGNED32, access: ro, default: 0x00020194}
  - {index: 0x1001, type: UNSIGNED8, access: ro, default: 0, pdo_mappable: yes}
  - {index: 0x1003, sub: 0, kind: array, type: UNSIGNED8, access: rw, default: 0}
  - {index: 0x1003, sub: 1..8, kind: array, type: UNSIGNED32, access: ro, default: 0}
  - {index: 0x1005, type: UNSIGNED32, access: rw, default: 0x80}
  - {index: 0x1007, type: UNSIGNED32, access: rw, default: 0}
  - {index: 0x1014, type: UNSIGNED32, access: rw, default: $NODEID+0x80}
  - {index: 0x1019, type: UNSIGNED8, access: rw, default: 0}
  - {index: 0x1400, sub: 0, kind: record, type: UNSIGNED8, access: ro, default: 5}
  - {index: 0x1400, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: $NODEID+0x200}
  - {index: 0x1400, sub: 2, kind: record, type: UNSIGNED8, access: rw, default: 255}
  - {index: 0x1400, sub: 5, kind: record, type: UNSIGNED16, access: rw, default: 0}
  - {index: 0x1600, sub: 0, kind: record, type: UNSIGNED8, access: rw, default: 2}
  - {index: 0x1600, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: 0x20000020}
  - {index: 0x1600, sub: 2, kind: record, type: UNSIGNED32, access: rw, default: 0x20010010}
  - {index: 0x1600, sub: 3..8, kind: record, type: UNSIGNED32, access: rw, default: 0}
  - {index: 0x1800, sub: 0, kind: record, type: UNSIGNED8, access: ro, default: 6}
  - {index: 0x1800, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: $NODEID+0x180}
  - {index: 0x1800, sub: 2, kind: record, type: UNSIGNED8, access: rw, default: 255}
  - {index: 0x1800, sub: 3, kind: record, type: UNSIGNED16, access: rw, default: 0}
  - {index: 0x1800, sub: 5, kind: record, type: UNSIGNED16, access: rw, default: 0}
  - {index: 0x1800, sub: 6, kind: record, type: UNSIGNED8, access: rw, default: 0}
  - {index: 0x1801, sub: 0, kind: record, type: UNSIGNED8, access: ro, default: 6}
  - {index: 0x1801, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: $NODEID+0x280}
  - {index: 0x1801, sub: 2, kind: record, type: UNSIGNED8, access: rw, default: 1}
  - {index: 0x1801, sub: 3, kind: record, type: UNSIGNED16, access: rw, default: 0}
  - {index: 0x1801, sub: 5, kind: record, type: UNSIGNED16, access: rw, default: 0}
  - {index: 0x1801, sub: 6, kind: record, type: UNSIGNED8, access: rw, default: 0}
  - {index: 0x1A00, sub: 0, kind: record, type: UNSIGNED8, access: rw, default: 2}
  - {index: 0x1A00, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: 0x20000020}
  - {index: 0x1A00, sub: 2, kind: record, type: UNSIGNED32, access: rw, default: 0x20010010}
  - {index: 0x1A00, sub: 3..8, kind: record, type: UNSIGNED32, access: rw, default: 0}
  - {index: 0x1A01, sub: 0, kind: record, type: UNSIGNED8, access: rw, default: 1}
  - {index: 0x1A01, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: 0x20030008}
  - {index: 0x1A01, sub: 2..8, kind: record, type: UNSIGNED32, access: rw, default: 0}
  - {index: 0x2000, type: UNSIGNED32, access: rw, default: 0x11223344, pdo_mappable: yes}
  - {index: 0x2001, type: UNSIGNED16, access: rw, default: 0x5566, pdo_mappable: yes}
  - {index: 0x2002, type: UNSIGNED8, access: rw, default: 0x77}
  - {index: 0x2003, type: UNSIGNED8, access: ro, default: 0x88, pdo_mappable: yes}
  - {index: 0x2004, type: BOOLEAN, access: rw, default: 0, pdo_mappable: yes}
  - {index: 0x2005, type: UNSIGNED64, access: rw, default: 0x0102030405060708, pdo_mappable: yes}
  - {index: 0x2006, type: UNSIGNED8, access: wo, default: 0, pdo_mappable: yes}
  - {index: 0x2007, type: UNSIGNED8, access: rw, default: 0, pdo_mappable: yes, hook: write}
)";
}

class PdoBus {
 public:
  explicit PdoBus(const std::string& options = "{}", Application* app = nullptr, std::uint64_t seed = 1)
      : profile_(config::parse_profile(pdo_profile(options), "pdo-test.yaml")),
        sim_(bus_.add(profile_, 5, app, std::nullopt, seed)) {
    bus_.power_on_all();
    bus_.run_for(ms(10));
    bus_.take();
  }

  test::SimBus& bus() { return bus_; }
  Node& node() { return sim_.node(); }
  TimeUs now() const { return bus_.now(); }

  void nmt(std::uint8_t cs) {
    bus_.inject(F(0x000, {cs, 0x05}));
    bus_.run_for(0);
  }
  void start() { nmt(0x01); }
  void sync() { bus_.inject(F(0x080, {})); }
  void sync(std::uint8_t counter) { bus_.inject(F(0x080, {counter})); }

  // A remote write (SDO download as the OD sees it): the abort code.
  SdoAbort write(std::uint16_t index, std::uint8_t sub, std::uint64_t v) {
    const OdEntry* e = node().od().find(index, sub);
    if (!e) return SdoAbort::kNoObject;
    std::uint8_t buf[8] = {};
    encode_u(e->type, v, buf);
    return node().write(*e, std::span<const std::uint8_t>(buf, type_size(e->type)), now());
  }
  std::uint64_t value(std::uint16_t index, std::uint8_t sub) { return node().values().u(index, sub); }
  void set(std::uint16_t index, std::uint8_t sub, std::uint64_t v) { node().values().set_u(index, sub, v); }

  // Frames sent since the last call, only those with CAN-ID id.
  std::vector<Sent> sent(std::uint32_t id) {
    std::vector<Sent> out;
    for (const Sent& s : bus_.take())
      if (s.frame.id == id) out.push_back(s);
    return out;
  }

 private:
  config::Profile profile_;
  test::SimBus bus_;
  test::SimNode& sim_;
};

}  // namespace cansim::pdo_test
