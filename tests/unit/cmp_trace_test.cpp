// Every frame of the manual's "CANopen-communication Examples" page (spec
// §11) replayed against trafag-cmp nodes 1, 4, 10 and 11 on one bus. The rows
// are independent examples, so each test sets up the state a row needs.
// XX bytes (measurement dependent) are checked against the simulated process.
#include <cmath>

#include "cmp_support.hpp"

namespace cansim::test {
namespace {

class CmpTrace : public ::testing::Test {
 public:
  CmpTrace() : b(cmp_profile(quiet("5 bar", "25 degC"))) {
    for (std::uint8_t id : {1, 4, 10, 11}) nodes[id] = &b.add(id, id);
    b.boot();
    b.bus.take();
  }
  CmpBus b;
  SimNode* nodes[128] = {};
};

TEST_F(CmpTrace, NmtStartStopPreopAllNodes) {
  b.nmt(0x01, 0x00);  // Start all nodes (OPERATIONAL)
  for (std::uint8_t id : {1, 4, 10, 11}) EXPECT_EQ(nodes[id]->node().state(), NmtState::kOperational);
  b.nmt(0x02, 0x00);  // Stop all nodes (STOPPED)
  for (std::uint8_t id : {1, 4, 10, 11}) EXPECT_EQ(nodes[id]->node().state(), NmtState::kStopped);
  b.bus.take();
  // After "Stop all nodes" SDO is not answered (why the rows are independent).
  EXPECT_TRUE(b.sdo(1, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}).empty());
  b.nmt(0x80, 0x00);  // Preop. all nodes (PRE-OPERATIONAL)
  for (std::uint8_t id : {1, 4, 10, 11}) EXPECT_EQ(nodes[id]->node().state(), NmtState::kPreOperational);
}

// The page shows no answer to the resets; CiA 301 boot-up frames follow
// (resolved behaviour, spec §11 issues).
TEST_F(CmpTrace, ResetAllNodesThenOnlyNode10) {
  b.nmt(0x01, 0x00);
  b.bus.take();
  const TimeUs t0 = b.bus.now();
  b.nmt(0x81, 0x00);  // Reset all nodes (INITIALISING)
  b.bus.run_for(ms(5));
  auto out = b.bus.take();
  ASSERT_EQ(out.size(), 4u) << to_string(out);
  for (const Sent& s : out) {
    EXPECT_EQ(s.time, t0);
    EXPECT_EQ(s.frame.dlc, 1);
    EXPECT_EQ(s.frame.data[0], 0x00);
  }
  EXPECT_EQ(only(out, 0x701).size(), 1u);
  EXPECT_EQ(only(out, 0x70A).size(), 1u);
  b.nmt(0x81, 0x0A);  // Reset only node 10
  b.bus.run_for(ms(5));
  out = b.bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x70A, {0x00}));
}

TEST_F(CmpTrace, ReadPressureAsFloat) {
  const TimeUs t0 = b.bus.now();
  auto out = b.sdo(1, {0x40, 0x30, 0x61, 0x01, 0, 0, 0, 0});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].time, t0);
  const CanFrame& r = out[0].frame;
  EXPECT_EQ(r.id, 0x581u);
  EXPECT_EQ(r.dlc, 8);
  EXPECT_EQ(r.data[0], 0x43);  // REAL32: 4 bytes indicated
  EXPECT_EQ(r.data[1], 0x30);
  EXPECT_EQ(r.data[2], 0x61);
  EXPECT_EQ(r.data[3], 0x01);
  EXPECT_NEAR(CmpBus::f32(r), 5.0, 10.0 / 8192);  // bar, within one 13-bit quantum
}

TEST_F(CmpTrace, ReadTemperatureAsInt16) {
  auto out = b.sdo(1, {0x40, 0x30, 0x71, 0x02, 0, 0, 0, 0});
  ASSERT_EQ(out.size(), 1u);
  const CanFrame& r = out[0].frame;
  EXPECT_EQ(r.id, 0x581u);
  EXPECT_EQ(r.data[0], 0x4B);  // INTEGER16: 2 bytes indicated
  EXPECT_EQ(r.data[1], 0x30);
  EXPECT_EQ(r.data[2], 0x71);
  EXPECT_EQ(r.data[3], 0x02);
  EXPECT_EQ(r.data[6], 0x00);
  EXPECT_EQ(r.data[7], 0x00);
  const auto t = std::int16_t(r.data[4] | r.data[5] << 8);
  EXPECT_NEAR(t, 250, 1);  // 25.0 degC at one decimal digit
}

TEST_F(CmpTrace, Node10SetPressureUnitToKpa) {
  auto out = b.sdo(10, {0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0x22, 0x03});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x58A, {0x60, 0x31, 0x61, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(nodes[10]->node().values().u(0x6131, 1), 0x03220000u);
  EXPECT_EQ(nodes[1]->node().values().u(0x6131, 1), 0x004E0000u);  // only node 10
}

TEST_F(CmpTrace, Node11SetTemperatureDecimalsTo2) {
  auto out = b.sdo(11, {0x22, 0x32, 0x61, 0x02, 0x02, 0x00, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x58B, {0x60, 0x32, 0x61, 0x02, 0, 0, 0, 0}));
  EXPECT_EQ(nodes[11]->node().values().u(0x6132, 2), 2u);
}

TEST_F(CmpTrace, SetPressureFilterTo1000ms) {
  auto out = b.sdo(1, {0x22, 0xA1, 0x61, 0x01, 0xE8, 0x03, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0xA1, 0x61, 0x01, 0, 0, 0, 0}));
}

// The manual prints "8504": OCR-merged bytes 85 04 (COB-ID 0x485).
TEST_F(CmpTrace, SwitchOnPdo4OnCobId485) {
  auto out = b.sdo(1, {0x22, 0x03, 0x18, 0x01, 0x85, 0x04, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x03, 0x18, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(nodes[1]->node().values().u(0x1803, 1), 0x485u);
}

TEST_F(CmpTrace, MapPInt32ToPdo1) {
  auto out = b.sdo(1, {0x22, 0x00, 0x21, 0x01, 0x05, 0x00, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x00, 0x21, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(nodes[1]->node().values().u(0x1A00, 1), 0x91300120u);
}

TEST_F(CmpTrace, CyclicTransmitAndCycleTimeOnPdo1) {
  auto out = b.sdo(1, {0x22, 0x00, 0x18, 0x02, 0xFF, 0x00, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x00, 0x18, 0x02, 0, 0, 0, 0}));
  out = b.sdo(1, {0x22, 0x00, 0x18, 0x05, 0x64, 0x00, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x00, 0x18, 0x05, 0, 0, 0, 0}));
  EXPECT_EQ(nodes[1]->node().values().u(0x1800, 5), 100u);
}

// The manual prints "1001" for the bytes 10 01 (index 0x1010 / 0x1011, sub 1).
TEST_F(CmpTrace, SaveAllAndRestoreFactorySettings) {
  auto out = b.sdo(1, {0x22, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(nodes[1]->storage.saves, 1);
  out = b.sdo(1, {0x22, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0}));
}

TEST_F(CmpTrace, WriteToReadOnlyObjectAborts) {
  auto out = b.sdo(1, {0x22, 0x00, 0x10, 0x00, 0x78, 0x56, 0x34, 0x12});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06}));
}

// Remote frame with DLC 4 on 0x181 -> one TPDO1 frame with P as INTEGER32
// (mapping mode 5, 3 decimal digits: 5 bar -> 5000).
TEST_F(CmpTrace, Pdo1RemoteTransmissionRequest) {
  ASSERT_EQ(b.download(1, 0x1800, 5, 0).data[0], 0x60);  // no cyclic frames in the way
  b.nmt(0x01, 0x01);
  b.bus.run_for(ms(10));
  b.bus.take();
  const TimeUs t0 = b.bus.now();
  b.bus.inject(CanFrame::remote(0x181, 4));
  b.bus.run_for(ms(1));
  auto out = only(b.bus.take(), 0x181);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].time, t0);
  EXPECT_EQ(out[0].frame.dlc, 4);
  EXPECT_FALSE(out[0].frame.rtr());
  const auto p = std::int32_t(out[0].frame.data[0] | out[0].frame.data[1] << 8 | out[0].frame.data[2] << 16 |
                              out[0].frame.data[3] << 24);
  EXPECT_NEAR(p, 5000, 2);
}

// N=4: life guarding stops -> EMCY 30 81 11 00 00 00 00 00 on 0x084 (the
// manual prints "3081": bytes 30 81; the trailing mark is a footnote).
TEST_F(CmpTrace, Node4NodeguardError) {
  ASSERT_EQ(b.download(4, 0x100C, 0, 100).data[0], 0x60);
  ASSERT_EQ(b.download(4, 0x100D, 0, 3).data[0], 0x60);
  b.nmt(0x01, 0x04);
  b.bus.inject(CanFrame::remote(0x704, 1));
  const TimeUs guarded = b.bus.now();
  b.bus.run_for(ms(400));
  auto emcy = only(b.bus.take(), 0x084);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(emcy[0].frame, F(0x084, {0x30, 0x81, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_EQ(emcy[0].time, guarded + ms(300));
  EXPECT_EQ(nodes[4]->node().state(), NmtState::kPreOperational);  // "the node changes to PRE-OPERATIONAL"
}

}  // namespace
}  // namespace cansim::test
