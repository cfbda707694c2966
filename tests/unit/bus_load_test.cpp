// The offered traffic estimated from a node's OD (daemon/bus_load): the
// figure the daemon's start-up and reload warnings and `cansimctl stats`
// compare with the bus's capacity. generic-404's defaults worked out by
// hand from profiles/generic-404.yaml.
#include <gtest/gtest.h>

#include "daemon/bus_load.hpp"
#include "support/sim.hpp"

namespace cansim::test {
namespace {

using daemon::estimate_traffic;
using daemon::frame_bits;

class BusLoad : public ::testing::Test {
 protected:
  BusLoad() : node(bus.add(load_repo_profile("generic-404"), 0x10)) { bus.power_on_all(); }
  void set(std::uint16_t index, std::uint8_t sub, std::uint64_t value) {
    node->values().set_u(*node->od().find(index, sub), value);
  }
  SimBus bus;
  SimNode& node;
};

TEST(FrameBits, StandardAndExtendedFramesWithoutStuffing) {
  EXPECT_EQ(frame_bits(8), 111);
  EXPECT_EQ(frame_bits(0), 47);
  EXPECT_EQ(frame_bits(8, true), 131);
  EXPECT_EQ(daemon::stuffed_frame_bits(8), 135);
}

// Heartbeat 1000 ms (1 frame of 1 byte a second) and TPDO1 every 100 ms
// (its event timer, 5 bytes: REAL32 + status). TPDO2 follows SYNC, which
// this node does not know of (0x1006 = 0); TPDO3 is RTR-only (253); TPDO4's
// COB-ID is invalid.
TEST_F(BusLoad, GenericDefaultsAreTheHeartbeatAndTpdo1) {
  const daemon::Traffic t = estimate_traffic(node.node());
  EXPECT_DOUBLE_EQ(t.frames_per_s, 11);
  EXPECT_DOUBLE_EQ(t.bits_per_s, frame_bits(1) + 10 * frame_bits(5));
}

// A SYNC every 10 ms: TPDO2 (type 1) answers each one; at type 4 every fourth.
TEST_F(BusLoad, SynchronousTpdosFollowTheSyncPeriod) {
  set(0x1006, 0, 10'000);
  const double before = estimate_traffic(node.node()).frames_per_s;
  EXPECT_DOUBLE_EQ(before, 11 + 100);
  set(0x1801, 2, 4);
  EXPECT_DOUBLE_EQ(estimate_traffic(node.node()).frames_per_s, 11 + 25);
}

TEST_F(BusLoad, AnInvalidTpdoOrAStoppedHeartbeatOffersNothing) {
  set(0x1800, 1, 0x80000000u | 0x190);
  set(0x1017, 0, 0);
  EXPECT_DOUBLE_EQ(estimate_traffic(node.node()).frames_per_s, 0);
  // TPDO4 made valid with a 50 ms event timer: 20 frames a second.
  set(0x1803, 1, 0x490);
  set(0x1803, 5, 50);
  EXPECT_DOUBLE_EQ(estimate_traffic(node.node()).frames_per_s, 20);
}

}  // namespace
}  // namespace cansim::test
