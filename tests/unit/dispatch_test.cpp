// COB-ID dispatch: the table itself, and the loop re-keying a node when its
// rx set changes (LSS node-ID change, RPDO COB-ID writes incl. 29-bit).
#include <gtest/gtest.h>

#include "io/dispatch.hpp"
#include "io/loop_core.hpp"
#include "support/sim.hpp"

namespace cansim::io {
namespace {

using test::F;
using Ids = std::vector<std::uint32_t>;

Ids to_ids(std::span<const std::uint32_t> s) { return Ids(s.begin(), s.end()); }

CanFrame ext(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  CanFrame f = F(id, bytes);
  f.flags |= CanFrame::kExtended;
  return f;
}

TEST(RxDispatch, StandardAndExtendedIdentifiersAreSeparateKeys) {
  RxDispatch d;
  const std::uint32_t eff = 0x80000000u;  // services' 29-bit marker (CAN_EFF_FLAG position)
  d.set(0, Ids{0x000, 0x123, 0x123 | eff, 0x1ABCDEF0 | eff});
  d.set(1, Ids{0x000, 0x124});
  EXPECT_EQ(to_ids(d.lookup(F(0x000, {}))), (Ids{0, 1}));
  EXPECT_EQ(to_ids(d.lookup(F(0x123, {}))), (Ids{0}));
  EXPECT_EQ(to_ids(d.lookup(ext(0x123, {}))), (Ids{0}));
  EXPECT_EQ(to_ids(d.lookup(ext(0x124, {}))), Ids{});
  EXPECT_EQ(to_ids(d.lookup(ext(0x1ABCDEF0, {}))), (Ids{0}));
  EXPECT_EQ(to_ids(d.lookup(F(0x7FF, {}))), Ids{});
}

TEST(RxDispatch, CiaBit29AndLargeIdentifiersMean29Bit) {
  RxDispatch d;
  d.set(3, Ids{0x20000181, 0x12345});
  EXPECT_EQ(to_ids(d.lookup(F(0x181, {}))), Ids{});
  EXPECT_EQ(to_ids(d.lookup(ext(0x181, {}))), (Ids{3}));
  EXPECT_EQ(to_ids(d.lookup(ext(0x12345, {}))), (Ids{3}));
}

TEST(RxDispatch, DuplicatesRegisterOnceAndSetReplacesTheOldSet) {
  RxDispatch d;
  d.set(0, Ids{0x601, 0x601, 0x000});
  EXPECT_EQ(to_ids(d.lookup(F(0x601, {}))), (Ids{0}));
  EXPECT_EQ(to_ids(d.registered(0)), (Ids{0x000, 0x601}));
  d.set(0, Ids{0x602, 0x000});
  EXPECT_EQ(to_ids(d.lookup(F(0x601, {}))), Ids{});
  EXPECT_EQ(to_ids(d.lookup(F(0x602, {}))), (Ids{0}));
  d.remove(0);
  EXPECT_EQ(to_ids(d.lookup(F(0x000, {}))), Ids{});
  EXPECT_EQ(to_ids(d.registered(0)), Ids{});
}

class DispatchLoopTest : public ::testing::Test {
 protected:
  DispatchLoopTest() : profile(test::load_repo_profile("generic-404")), tx(&core.now()) {
    bus = core.add_bus("vcan0", tx, 3);
  }
  NodeRef add(std::uint8_t id) {
    NodeRef r = core.add_node(bus, config::node_setup(profile, id));
    core.power_on(r, core.now());
    return r;
  }
  std::vector<CanFrame> sent() {
    std::vector<CanFrame> out;
    for (auto& s : tx.take()) out.push_back(s.frame);
    return out;
  }
  void sdo_write_u32(std::uint8_t id, std::uint16_t index, std::uint8_t sub, std::uint32_t v) {
    core.receive(bus,
                 F(0x600 + id, {0x23, std::uint8_t(index), std::uint8_t(index >> 8), sub, std::uint8_t(v),
                                std::uint8_t(v >> 8), std::uint8_t(v >> 16), std::uint8_t(v >> 24)}),
                 core.now());
    ASSERT_EQ(
        sent(),
        (std::vector<CanFrame>{F(0x580 + id, {0x60, std::uint8_t(index), std::uint8_t(index >> 8), sub, 0, 0, 0, 0})}));
  }
  CanFrame upload_1000(std::uint8_t id) { return F(0x600 + id, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}); }
  CanFrame answer_1000(std::uint8_t id) { return F(0x580 + id, {0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}); }

  config::Profile profile;
  LoopCore core;
  MemoryTransport tx;
  BusId bus;
};

TEST_F(DispatchLoopTest, LssConfiguredNodeIdTakesEffectAtResetCommunication) {
  NodeRef n = add(0x10);
  sent();
  core.receive(bus, F(0x7E5, {0x04, 0x01, 0, 0, 0, 0, 0, 0}), 0);
  core.receive(bus, F(0x7E5, {0x11, 0x30, 0, 0, 0, 0, 0, 0}), 0);
  EXPECT_EQ(sent(), (std::vector<CanFrame>{F(0x7E4, {0x11, 0x00, 0, 0, 0, 0, 0, 0})}));
  core.receive(bus, F(0x7E5, {0x04, 0x00, 0, 0, 0, 0, 0, 0}), 0);
  core.receive(bus, upload_1000(0x10), ms(1));  // still the old node-ID
  EXPECT_EQ(sent(), (std::vector<CanFrame>{answer_1000(0x10)}));
  core.receive(bus, F(0x000, {0x82, 0x10}), ms(2));
  EXPECT_EQ(sent(), (std::vector<CanFrame>{F(0x730, {0x00})}));
  EXPECT_EQ(core.node(n).node_id(), 0x30);
  core.receive(bus, upload_1000(0x10), ms(3));
  EXPECT_EQ(sent(), std::vector<CanFrame>{});
  core.receive(bus, upload_1000(0x30), ms(4));
  EXPECT_EQ(sent(), (std::vector<CanFrame>{answer_1000(0x30)}));
}

TEST_F(DispatchLoopTest, UnconfiguredNodeBootsWithItsLssNodeId) {
  NodeRef n = add(0xFF);
  EXPECT_EQ(sent(), std::vector<CanFrame>{});  // CiA 305: no boot-up without a node-ID
  core.receive(bus, F(0x7E5, {0x04, 0x01, 0, 0, 0, 0, 0, 0}), 0);
  core.receive(bus, F(0x7E5, {0x11, 0x05, 0, 0, 0, 0, 0, 0}), 0);
  core.receive(bus, F(0x7E5, {0x04, 0x00, 0, 0, 0, 0, 0, 0}), ms(1));
  EXPECT_EQ(sent(), (std::vector<CanFrame>{F(0x7E4, {0x11, 0x00, 0, 0, 0, 0, 0, 0}), F(0x705, {0x00})}));
  EXPECT_EQ(core.node(n).node_id(), 5);
  core.receive(bus, upload_1000(5), ms(2));
  EXPECT_EQ(sent(), (std::vector<CanFrame>{answer_1000(5)}));
}

TEST_F(DispatchLoopTest, RpdoCobIdWriteReroutesItsFrames) {
  NodeRef n = add(0x10);
  core.receive(bus, F(0x000, {0x01, 0x10}), 0);  // OPERATIONAL: RPDOs are processed
  sent();
  sdo_write_u32(0x10, 0x1400, 1, 0x80000210);  // disable, then a new COB-ID
  sdo_write_u32(0x10, 0x1400, 1, 0x00000345);
  core.receive(bus, F(0x210, {1, 0, 0, 0, 2, 0}), ms(1));
  EXPECT_EQ(core.node(n).values().u(0x2100, 1), 0u);
  core.receive(bus, F(0x345, {0x78, 0x56, 0x34, 0x12, 0xCD, 0xAB}), ms(2));
  EXPECT_EQ(core.node(n).values().u(0x2100, 1), 0x12345678u);
  EXPECT_EQ(core.node(n).values().u(0x2100, 2), 0xABCDu);
}

TEST_F(DispatchLoopTest, RpdoWith29BitCobIdListensToExtendedFrames) {
  NodeRef n = add(0x10);
  core.receive(bus, F(0x000, {0x01, 0x10}), 0);
  sent();
  sdo_write_u32(0x10, 0x1400, 1, 0x80000210);
  sdo_write_u32(0x10, 0x1400, 1, 0x20012345);              // CiA 301: bit 29 = 29-bit identifier
  core.receive(bus, F(0x345, {1, 0, 0, 0, 1, 0}), ms(1));  // 11-bit 0x345: not ours
  EXPECT_EQ(core.node(n).values().u(0x2100, 1), 0u);
  core.receive(bus, ext(0x12345, {0x04, 0x03, 0x02, 0x01, 0x02, 0x01}), ms(2));
  EXPECT_EQ(core.node(n).values().u(0x2100, 1), 0x01020304u);
  EXPECT_EQ(core.node(n).values().u(0x2100, 2), 0x0102u);
}

TEST_F(DispatchLoopTest, HeartbeatConsumerEntryAddsTheWatchedProducer) {
  add(0x10);
  NodeRef watcher = add(0x11);
  sent();
  // 0x1016:01 = watch node 0x10 with 1500 ms: node 0x10's heartbeats (every
  // 1000 ms) now reach node 0x11 through the loop, so it never times out.
  sdo_write_u32(0x11, 0x1016, 1, 0x001005DC);
  core.run_until(ms(5000));
  for (const CanFrame& f : sent()) EXPECT_NE(f.id, 0x91u) << "consumer timed out: " << test::to_string(f);
  // Node 0x10 stops beating (0x1017 = 0): the consumer reports the timeout.
  core.receive(bus, F(0x610, {0x2B, 0x17, 0x10, 0x00, 0, 0, 0, 0}), ms(5000));
  core.run_until(ms(8000));
  bool emcy = false;
  for (const CanFrame& f : sent()) emcy |= f.id == 0x91 && f.data[0] == 0x30 && f.data[1] == 0x81;
  EXPECT_TRUE(emcy) << "no heartbeat consumer EMCY 0x8130 from node 0x11";
  EXPECT_EQ(core.node(watcher).state(), NmtState::kPreOperational);
}

}  // namespace
}  // namespace cansim::io
