// Shared fixture for the NMT / error control / SYNC / EMCY / store tests: a
// compact profile with every communication object those services use, nodes
// on a SimBus, and helpers for exact frame-by-frame expectations.
#pragma once

#include <gtest/gtest.h>

#include <deque>
#include <string>

#include "config/profile.hpp"
#include "support/sim.hpp"

namespace cansim::nmt_test {

using test::F;
using test::Sent;
using test::SimBus;
using test::SimNode;

// Node-ID 5. No heartbeat by default so logs hold only what a test provokes.
inline std::string profile_text(const std::string& options, const std::string& extra_objects) {
  return R"(
name: nmt-test
node_id: 5
bit_rate: 250
options: )" +
         options + R"(
objects:
  - {index: 0x1000, type: UNSIGNED32, access: ro, default: 0x00020194}
  - {index: 0x1001, type: UNSIGNED8, access: ro, default: 0}
  - {index: 0x1003, sub: 0, kind: array, type: UNSIGNED8, access: rw, default: 0}
  - {index: 0x1003, sub: 1..4, kind: array, type: UNSIGNED32, access: ro, default: 0}
  - {index: 0x1005, type: UNSIGNED32, access: rw, default: 0x80, persistent: yes}
  - {index: 0x1006, type: UNSIGNED32, access: rw, default: 0, persistent: yes}
  - {index: 0x1007, type: UNSIGNED32, access: rw, default: 0, persistent: yes}
  - {index: 0x100C, type: UNSIGNED16, access: rw, default: 0, persistent: yes}
  - {index: 0x100D, type: UNSIGNED8, access: rw, default: 0, persistent: yes}
  - {index: 0x1010, sub: 0, kind: array, type: UNSIGNED8, access: ro, default: 4}
  - {index: 0x1010, sub: 1..4, kind: array, type: UNSIGNED32, access: rw, default: 1}
  - {index: 0x1011, sub: 0, kind: array, type: UNSIGNED8, access: ro, default: 4}
  - {index: 0x1011, sub: 1..4, kind: array, type: UNSIGNED32, access: rw, default: 1}
  - {index: 0x1014, type: UNSIGNED32, access: rw, default: $NODEID+0x80, persistent: yes}
  - {index: 0x1015, type: UNSIGNED16, access: rw, default: 0, persistent: yes}
  - {index: 0x1016, sub: 0, kind: array, type: UNSIGNED8, access: ro, default: 2}
  - {index: 0x1016, sub: 1..2, kind: array, type: UNSIGNED32, access: rw, default: 0, persistent: yes}
  - {index: 0x1017, type: UNSIGNED16, access: rw, default: 0, persistent: yes}
  - {index: 0x1019, type: UNSIGNED8, access: rw, default: 0, persistent: yes}
  - {index: 0x2000, type: UNSIGNED32, access: rw, default: 7, persistent: application}
  - {index: 0x2001, type: UNSIGNED16, access: rw, default: 9}
  - {index: 0x2002, type: VISIBLE_STRING, access: rw, max_length: 16, default: "abc", persistent: application}
  - {index: 0x3000, type: UNSIGNED8, access: rw, default: 3, persistent: 4}
)" + extra_objects;
}

// 0x1029 with a given communication-error behaviour.
inline std::string error_behaviour(int value) {
  return "  - {index: 0x1029, sub: 0, kind: array, type: UNSIGNED8, access: ro, default: 1}\n"
         "  - {index: 0x1029, sub: 1, kind: array, type: UNSIGNED8, access: rw, default: " +
         std::to_string(value) + "}\n";
}

inline std::string S(std::initializer_list<Sent> frames) { return test::to_string(std::vector<Sent>(frames)); }

class Harness : public ::testing::Test {
 protected:
  SimNode& add(std::uint8_t id, const std::string& options = "{}", const std::string& extra = "",
               Application* app = nullptr) {
    profiles_.push_back(config::parse_profile(profile_text(options, extra)));
    return bus.add(profiles_.back(), id, app);
  }
  SimNode& add_profile(config::Profile p, std::uint8_t id) {
    profiles_.push_back(std::move(p));
    return bus.add(profiles_.back(), id);
  }
  std::string take() { return test::to_string(bus.take()); }
  void inject(const CanFrame& f) { bus.inject(f); }
  void nmt(std::uint8_t cs, std::uint8_t id) { bus.inject(F(0x000, {cs, id})); }
  TimeUs now() const { return bus.now(); }

  // OD write as an SDO client would do it, `size` bytes little-endian.
  SdoAbort wr(SimNode& n, std::uint16_t index, std::uint8_t sub, std::uint64_t value, std::size_t size) {
    std::uint8_t b[8] = {};
    for (std::size_t i = 0; i < size; ++i) b[i] = std::uint8_t(value >> (8 * i));
    return n->write(index, sub, std::span<const std::uint8_t>(b, size), now());
  }
  SdoAbort wr32(SimNode& n, std::uint16_t i, std::uint8_t s, std::uint32_t v) { return wr(n, i, s, v, 4); }
  SdoAbort wr16(SimNode& n, std::uint16_t i, std::uint8_t s, std::uint16_t v) { return wr(n, i, s, v, 2); }
  SdoAbort wr8(SimNode& n, std::uint16_t i, std::uint8_t s, std::uint8_t v) { return wr(n, i, s, v, 1); }
  // OD read as an SDO client sees it; value 0 on refusal (check `why`).
  std::uint64_t rd(SimNode& n, std::uint16_t index, std::uint8_t sub, SdoAbort* why = nullptr) {
    std::span<const std::uint8_t> out;
    SdoAbort a = n->read(index, sub, now(), out);
    if (why) *why = a;
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < out.size() && i < 8 && ok(a); ++i) v |= std::uint64_t(out[i]) << (8 * i);
    return v;
  }

  std::deque<config::Profile> profiles_;  // outlives the bus
  SimBus bus;
};

}  // namespace cansim::nmt_test
