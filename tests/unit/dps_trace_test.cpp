// Honeywell DPS: every frame trace of the manual (docs/devices/dps.md,
// /work/shared/devices/honeywell-dps.md §11) replayed on the personality:
// master frames in, exact frames out at the times the trace implies.
#include <gtest/gtest.h>

#include "dps_support.hpp"

namespace cansim::test {
namespace {

using Trace = DpsFixture;

constexpr std::uint32_t kLssRx = 0x7E5, kLssTx = 0x7E4;

std::vector<CanFrame> lss(Trace& t, std::initializer_list<std::uint8_t> bytes) {
  t.master(kLssRx, bytes);
  t.bus.run_for(ms(1));
  return frames(t.bus.take());
}

TEST_F(Trace, Table03PointToPointNodeIdConfiguration) {
  boot();
  nmt(0x80);
  EXPECT_TRUE(lss(*this, {0x04, 0x01, 0, 0, 0, 0, 0, 0}).empty());
  EXPECT_EQ(lss(*this, {0x11, 0x7E, 0, 0, 0, 0, 0, 0}), one(kLssTx, {0x11, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(lss(*this, {0x17, 0, 0, 0, 0, 0, 0, 0}), one(kLssTx, {0x17, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(lss(*this, {0x04, 0x00, 0, 0, 0, 0, 0, 0}).empty());
  const TimeUs t = bus.now();
  nmt(0x81, 0x7F);
  bus.run_for(ms(1));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x77E, {0x00}));  // the new node-ID is active after the reset
  EXPECT_EQ(out[0].time, t);
}

// Table 4 starts at node 0x7E (Table 3's result) and moves the device back to 0x7F.
TEST_F(Trace, Table04NodeIdConfigurationOnNetwork) {
  boot();
  lss(*this, {0x04, 0x01, 0, 0, 0, 0, 0, 0});
  lss(*this, {0x11, 0x7E, 0, 0, 0, 0, 0, 0});
  lss(*this, {0x17, 0, 0, 0, 0, 0, 0, 0});
  lss(*this, {0x04, 0x00, 0, 0, 0, 0, 0, 0});
  nmt(0x81, 0x7F);
  bus.run_for(ms(1));
  ASSERT_EQ(frames(bus.take()), one(0x77E, {0x00}));

  nmt(0x80, 0x7E);
  EXPECT_TRUE(lss(*this, {0x40, 0x62, 0x03, 0x00, 0x00, 0, 0, 0}).empty());
  EXPECT_TRUE(lss(*this, {0x41, 0x50, 0x31, 0x44, 0x00, 0, 0, 0}).empty());
  EXPECT_TRUE(lss(*this, {0x42, 0x00, 0x00, 0x01, 0x00, 0, 0, 0}).empty());
  // "43 xx xx xx xx": the unit's serial number (0x1018:04 of this node).
  const auto serial = std::uint32_t(u(0x1018, 4));
  EXPECT_EQ(lss(*this, {0x43, std::uint8_t(serial), std::uint8_t(serial >> 8), std::uint8_t(serial >> 16),
                        std::uint8_t(serial >> 24), 0, 0, 0}),
            one(kLssTx, {0x44, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(lss(*this, {0x11, 0x7F, 0, 0, 0, 0, 0, 0}), one(kLssTx, {0x11, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(lss(*this, {0x17, 0, 0, 0, 0, 0, 0, 0}), one(kLssTx, {0x17, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(lss(*this, {0x04, 0x00, 0, 0, 0, 0, 0, 0}).empty());
  nmt(0x81, 0x7E);
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()), one(0x77F, {0x00}));
}

void bit_rate_tail(Trace& t) {
  EXPECT_EQ(lss(t, {0x13, 0x00, 0x04, 0, 0, 0, 0, 0}), one(kLssTx, {0x13, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(lss(t, {0x17, 0, 0, 0, 0, 0, 0, 0}), one(kLssTx, {0x17, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(lss(t, {0x04, 0x00, 0, 0, 0, 0, 0, 0}).empty());
  // "01 00": start all nodes; "Pressure data" = 0x6130:01, first PDO one event-timer period later.
  t.source->psi = 42.125;
  const TimeUs start = t.bus.now();
  t.nmt(0x01, 0x00);
  t.bus.run_for(ms(101));
  const auto out = t.bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x1FF, {0x8D, 0xA4, 0x00, 0x00}));  // 42125
  EXPECT_EQ(out[0].time, start + ms(100));
}

TEST_F(Trace, Table05PointToPointBitRateConfiguration) {
  boot();
  nmt(0x80);
  EXPECT_TRUE(lss(*this, {0x04, 0x01, 0, 0, 0, 0, 0, 0}).empty());
  bit_rate_tail(*this);
}

// Table 6 addresses "80 7E" to a 0x7F device: ignored (spec §12 item 9).
TEST_F(Trace, Table06BitRateConfigurationOnNetwork) {
  boot();
  nmt(0x80, 0x7E);
  lss(*this, {0x40, 0x62, 0x03, 0x00, 0x00, 0, 0, 0});
  lss(*this, {0x41, 0x50, 0x31, 0x44, 0x00, 0, 0, 0});
  lss(*this, {0x42, 0x00, 0x00, 0x01, 0x00, 0, 0, 0});
  const auto serial = std::uint32_t(u(0x1018, 4));
  EXPECT_EQ(lss(*this, {0x43, std::uint8_t(serial), std::uint8_t(serial >> 8), std::uint8_t(serial >> 16),
                        std::uint8_t(serial >> 24), 0, 0, 0}),
            one(kLssTx, {0x44, 0, 0, 0, 0, 0, 0, 0}));
  bit_rate_tail(*this);
}

// Table 8: heartbeats every 100 ms keep running through configure bit timing;
// after "15 E8 03" (1000 ms switch delay) nothing for 2 x 1000 ms, then
// heartbeats again at 100 ms. The comment "Configuration state" on the 0x15
// row is a manual error (spec §12 item 10). The manual prints the heartbeats
// as "7ff"; for node 0x7F the heartbeat COB-ID is 0x700 + 0x7F = 0x77F
// (Table 15 "0x700+Node-ID", Table 12 boot-up on 77F), so 0x77F is asserted.
TEST_F(Trace, Table08ActivateBitTiming) {
  boot();
  const TimeUs t0 = bus.now();
  EXPECT_EQ(frames(sdo({0x22, 0x17, 0x10, 0x00, 0x64, 0, 0, 0})), one(0x5FF, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  bus.run_until(t0 + ms(100));
  auto out = bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x77F, {0x7F}));
  EXPECT_EQ(out[0].time, t0 + ms(100));
  nmt(0x80);
  lss(*this, {0x04, 0x01, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(lss(*this, {0x13, 0x00, 0x04, 0, 0, 0, 0, 0}), one(kLssTx, {0x13, 0, 0, 0, 0, 0, 0, 0}));
  lss(*this, {0x04, 0x00, 0, 0, 0, 0, 0, 0});
  bus.run_until(t0 + ms(300));
  out = bus.take();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].time, t0 + ms(200));
  EXPECT_EQ(out[1].time, t0 + ms(300));
  for (const Sent& s : out) EXPECT_EQ(s.frame, F(0x77F, {0x7F}));
  bus.run_until(t0 + ms(390));
  lss(*this, {0x04, 0x01, 0, 0, 0, 0, 0, 0});
  const TimeUs activate = bus.now();  // 9 ms before the next heartbeat slot
  master(kLssRx, {0x15, 0xE8, 0x03, 0, 0, 0, 0, 0});
  master(kLssRx, {0x04, 0x00, 0, 0, 0, 0, 0, 0});  // received at the old rate, still processed
  bus.run_until(activate + ms(2000) - 1);
  EXPECT_TRUE(bus.take().empty());
  bus.run_until(activate + ms(2200));
  out = bus.take();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].frame, F(0x77F, {0x7F}));
  EXPECT_LE(out[0].time - activate, ms(2050));
  EXPECT_EQ(out[1].time - out[0].time, ms(100));
  EXPECT_EQ(node().lss().state(), LssSlave::State::kWaiting);
}

// §4.3, the text after Table 6: "The new bit rate is valid after a reset of
// the device. ... Performing a NMT reset node command will lead to error frames
// on the CANbus, because the master still has the previous bit rate." Table 5's
// LSS sequence with table 0 index 3 (250 kbit/s) on a device at 125 kbit/s,
// then NMT reset node. Returns the time of the reset node.
TimeUs store_250_then_reset_node(Trace& t) {
  EXPECT_TRUE(lss(t, {0x04, 0x01, 0, 0, 0, 0, 0, 0}).empty());
  EXPECT_EQ(lss(t, {0x13, 0x00, 0x03, 0, 0, 0, 0, 0}), one(kLssTx, {0x13, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(lss(t, {0x17, 0, 0, 0, 0, 0, 0, 0}), one(kLssTx, {0x17, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(lss(t, {0x04, 0x00, 0, 0, 0, 0, 0, 0}).empty());
  EXPECT_EQ(t.node().bit_rate_index(), 4);  // stored, still at 125 kbit/s until the reset
  const TimeUs reset = t.bus.now();
  t.nmt(0x81, 0x7F);
  return reset;
}

// The master stays at 125 kbit/s: after "81 7F" the DPS runs at 250 kbit/s, so
// nothing of it reaches the old bus (no boot-up, no SDO answer, start ignored);
// the master at 250 kbit/s reaches it. §4.3 recommends a power-off instead:
// the stored rate is also the rate of the next power-on.
TEST_F(Trace, Section43ResetNodeActivatesStoredBitRateOldBusSilent) {
  boot();
  store_250_then_reset_node(*this);
  bus.run_for(ms(1000));
  EXPECT_TRUE(bus.take().empty());  // no 77F [1] 00 at 125 kbit/s
  EXPECT_TRUE(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}).empty());
  nmt(0x01, 0x00);  // not heard at the old rate: no PDO follows
  bus.run_for(ms(500));
  EXPECT_TRUE(bus.take().empty());
  EXPECT_EQ(node().bit_rate_index(), 3);
  EXPECT_EQ(node().state(), NmtState::kPreOperational);

  node().set_bus_bit_rate(3);  // the master moves to 250 kbit/s
  EXPECT_EQ(frames(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));

  // Power cycle with the master back at 125 kbit/s: still silent there.
  sim->replace(kId);
  bus.take();
  node().power_on(now());
  bus.run_for(ms(1000));
  EXPECT_TRUE(bus.take().empty());
  EXPECT_EQ(node().bit_rate_index(), 3);
  // Power cycle with the master at 250 kbit/s: boot-up there, SDO answered.
  sim->replace(kId);
  node().set_bus_bit_rate(3);
  const TimeUs on = now();
  node().power_on(on);
  bus.run_for(ms(1));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x77F, {0x00}));
  EXPECT_EQ(out[0].time, on);
  EXPECT_EQ(frames(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
}

// The same sequence seen from a bus at the new rate: the master sends "81 7F"
// at 125 kbit/s and is at 250 kbit/s when the device restarts. The boot-up
// 77F [1] 00 comes at once, at 250 kbit/s; SDO is answered there.
struct BusFollowsReset : NodeObserver {
  std::uint8_t rate;
  explicit BusFollowsReset(std::uint8_t r) : rate(r) {}
  void on_nmt_state(Node& n, NmtState, NmtState now, TimeUs) override {
    if (now == NmtState::kInitialising) n.set_bus_bit_rate(rate);
  }
};

TEST_F(Trace, Section43ResetNodeBootsAtStoredBitRateOnNewBus) {
  boot();
  BusFollowsReset master_at_250(3);
  node().set_observer(&master_at_250);
  const TimeUs reset = store_250_then_reset_node(*this);
  node().set_observer(nullptr);
  bus.run_for(ms(1));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x77F, {0x00}));
  EXPECT_EQ(out[0].time, reset);
  EXPECT_EQ(node().bit_rate_index(), 3);
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  EXPECT_EQ(frames(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
  nmt(0x01, 0x00);  // start all at 250 kbit/s: TPDO1 after one event-timer period
  bus.run_for(ms(101));
  EXPECT_EQ(only(bus.take(), 0x1FF).size(), 1u);
}

// Tables 9-14: NMT commands (DLC 2) and the boot-up (DLC 1).
TEST_F(Trace, Tables09To14NmtCommandsAndBootUp) {
  bus.power_on_all();
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()), one(0x77F, {0x00}));  // Table 12
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  nmt(0x01);  // Table 9
  bus.run_for(ms(1));
  EXPECT_EQ(node().state(), NmtState::kOperational);
  nmt(0x02);  // Table 10
  bus.run_for(ms(1));
  EXPECT_EQ(node().state(), NmtState::kStopped);
  nmt(0x80);  // Table 11
  bus.run_for(ms(1));
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  EXPECT_TRUE(bus.take().empty());
  nmt(0x81);  // Table 13
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()), one(0x77F, {0x00}));
  nmt(0x82);  // Table 14
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()), one(0x77F, {0x00}));
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
}

// Tables 15/16 are a template: the heartbeat byte per state.
TEST_F(Trace, Tables15And16HeartbeatStates) {
  bus.power_on_all();
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()), one(0x77F, {0x00}));
  sdo({0x2B, 0x17, 0x10, 0x00, 50, 0, 0, 0});
  bus.run_for(ms(50));
  EXPECT_EQ(frames(bus.take()), one(0x77F, {0x7F}));
  nmt(0x01);
  bus.run_for(ms(50));
  EXPECT_EQ(on(0x77F).back().frame, F(0x77F, {0x05}));
  nmt(0x02);
  bus.run_for(ms(50));
  EXPECT_EQ(frames(bus.take()), one(0x77F, {0x04}));
}

// Table 19 with the manual's 0x60 upload responses (default). The manual's
// last value "78 0D" (3.448 bar) is 50 psi converted with rounding the spec
// cannot reproduce: 50 psi = 3.44738 bar -> 3447 = "77 0D" (spec §12 item 25).
TEST_F(Trace, Table19ChangeUnitsFromPsiToBar) {
  boot();
  source->psi = 50.0;
  EXPECT_EQ(frames(sdo({0x40, 0x31, 0x61, 0x01, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x31, 0x61, 0x01, 0x00, 0x00, 0xAB, 0x00}));
  EXPECT_EQ(frames(sdo({0x40, 0x30, 0x61, 0x01, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x30, 0x61, 0x01, 0x50, 0xC3, 0x00, 0x00}));
  EXPECT_EQ(frames(sdo({0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0x4E, 0x00})),
            one(0x5FF, {0x60, 0x31, 0x61, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(frames(sdo({0x40, 0x31, 0x61, 0x01, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x31, 0x61, 0x01, 0x00, 0x00, 0x4E, 0x00}));
  EXPECT_EQ(frames(sdo({0x40, 0x30, 0x61, 0x01, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x30, 0x61, 0x01, 0x77, 0x0D, 0x00, 0x00}));
}

// Table 25: boot-up, start, PDO with 0.005 psi every 100 ms.
TEST_F(Trace, Table25GettingThePressureData) {
  source->psi = 0.005;
  bus.power_on_all();
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()), one(0x77F, {0x00}));
  const TimeUs start = bus.now();
  nmt(0x01);
  bus.run_for(ms(350));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 3u);
  for (std::size_t k = 0; k < out.size(); ++k) {
    EXPECT_EQ(out[k].frame, F(0x1FF, {0x05, 0x00, 0x00, 0x00}));
    EXPECT_EQ(out[k].time, start + ms(100) * TimeUs(k + 1));
  }
}

// Table 26: remap TPDO1 to the raw value 0x7100:01 (INTEGER16, DLC 2).
// 0x1A00:00 is written once with 0x22 and once with 0x2F: both accepted.
TEST_F(Trace, Table26MapRawPressureDataIntoPdo) {
  boot();
  source->psi = 50.0;
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x18, 0x01, 0xFF, 0x01, 0x00, 0xC0})),
            one(0x5FF, {0x60, 0x00, 0x18, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x1A, 0x00, 0x00, 0, 0, 0})), one(0x5FF, {0x60, 0x00, 0x1A, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x1A, 0x01, 0x10, 0x01, 0x00, 0x71})),
            one(0x5FF, {0x60, 0x00, 0x1A, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(frames(sdo({0x2F, 0x00, 0x1A, 0x00, 0x01, 0, 0, 0})), one(0x5FF, {0x60, 0x00, 0x1A, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x18, 0x01, 0xFF, 0x01, 0x00, 0x40})),
            one(0x5FF, {0x60, 0x00, 0x18, 0x01, 0, 0, 0, 0}));
  nmt(0x01);
  bus.run_for(ms(100));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 1u);
  // (50 + 5) / 110 x 4095 = 2047.5 -> 2048 = 0x0800
  EXPECT_EQ(out[0].frame, F(0x1FF, {0x00, 0x08}));
}

// Table 27: type 0 sends on SYNC only when the pressure changed. The
// manual's bytes 00 10 00 00 / 00 20 00 00 are 4.096 / 8.192 psi (its
// "[1 psi] / [2 psi]" annotations are wrong, spec §12 item 6): the test
// uses those pressures so the bytes match. The manual's 7-byte SDO answer
// is sent with 8 bytes.
TEST_F(Trace, Table27SynchronousAcyclic) {
  boot();
  nmt(0x01);
  bus.run_for(ms(1));
  bus.take();
  source->psi = 4.096;
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x18, 0x02, 0x00, 0, 0, 0})), one(0x5FF, {0x60, 0x00, 0x18, 0x02, 0, 0, 0, 0}));
  bus.run_for(ms(50));
  sync();
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()), one(0x1FF, {0x00, 0x10, 0x00, 0x00}));
  sync();  // no change: nothing
  bus.run_for(ms(1));
  EXPECT_TRUE(bus.take().empty());
  source->psi = 8.192;
  bus.run_for(ms(20));
  sync();
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()), one(0x1FF, {0x00, 0x20, 0x00, 0x00}));
}

// Table 28: type 3, one PDO on the 3rd SYNC after the write (8.192 psi, see Table 27).
TEST_F(Trace, Table28SynchronousCyclic) {
  boot();
  nmt(0x01);
  bus.run_for(ms(1));
  source->psi = 8.192;
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x18, 0x02, 0x03, 0, 0, 0})), one(0x5FF, {0x60, 0x00, 0x18, 0x02, 0, 0, 0, 0}));
  bus.take();
  for (int k = 0; k < 2; ++k) {
    sync();
    bus.run_for(ms(10));
  }
  EXPECT_TRUE(bus.take().empty());
  const TimeUs third = bus.now();
  sync();
  bus.run_for(ms(10));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x1FF, {0x00, 0x20, 0x00, 0x00}));
  EXPECT_EQ(out[0].time, third);
}

// Table 29: type 0xFE (or 0xFF), then event timer 1000 ms.
TEST_F(Trace, Table29Asynchronous) {
  boot();
  for (std::uint8_t type : {0xFE, 0xFF}) {
    SCOPED_TRACE(int(type));
    nmt(0x01);
    bus.run_for(ms(1));
    bus.take();
    source->psi = 1.0;
    EXPECT_EQ(frames(sdo({0x22, 0x00, 0x18, 0x02, type, 0, 0, 0})), one(0x5FF, {0x60, 0x00, 0x18, 0x02, 0, 0, 0, 0}));
    const TimeUs t = bus.now();
    master(0x67F, {0x22, 0x00, 0x18, 0x05, 0xE8, 0x03, 0, 0});
    bus.run_for(ms(1));
    EXPECT_EQ(frames(bus.take()), one(0x5FF, {0x60, 0x00, 0x18, 0x05, 0, 0, 0, 0}));
    bus.run_until(t + ms(3500));
    const auto out = bus.take();
    ASSERT_EQ(out.size(), 3u);
    for (std::size_t k = 0; k < out.size(); ++k) {
      EXPECT_EQ(out[k].frame, F(0x1FF, {0xE8, 0x03, 0x00, 0x00}));
      EXPECT_EQ(out[k].time, t + ms(1000) * TimeUs(k + 1));
    }
    nmt(0x81);  // PDO parameters are not stored: back to 0xFF / 100 ms
    bus.run_for(ms(1));
  }
}

// Table 30: autozero at the applied pressure.
TEST_F(Trace, Table30AutoZero) {
  boot();
  source->psi = 0.25;  // "apply zero pressure": what the sensor reads then is the offset to remove
  EXPECT_EQ(frames(sdo({0x22, 0x25, 0x61, 0x01, 0x7A, 0x65, 0x72, 0x6F})),
            one(0x5FF, {0x60, 0x25, 0x61, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(i32(0x6130, 1), 0);
  EXPECT_EQ(i32(0x6124, 1), -250);
}

}  // namespace
}  // namespace cansim::test
