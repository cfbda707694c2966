// Every frame trace of the P92C spec (§12, from the manual's §3.5, §3.6, §4.1,
// §4.2, §5.2-§5.4) replayed against the personality: frames in, exact frames
// out, at the time the trace implies. "xx" bytes are sent as 00.
#include "p92c_support.hpp"

namespace cansim::test {
namespace {

using Trace = P92cFixture;

// ---- boot-up, start, TPDO (manual §3.5, §5.2)

TEST_F(Trace, BootUpIsOneZeroByteOn0x701) {
  bus.power_on_all();
  bus.run_for(ms(1));
  EXPECT_EQ(to_string(bus.take()), expected(0, {{0, F(0x701, {0x00})}}));
}

// "The Start_Remote_Node will be answered with a data message (PDO)", then
// cyclically with the default event timer of 1000 ms.
TEST_F(Trace, StartRemoteNodeIsAnsweredWithThePdoThenCyclic) {
  boot();
  const TimeUs t0 = now();
  bus.take();
  bus.inject(F(0x000, {0x01, 0x01}));
  bus.run_for(ms(2500));
  const CanFrame pdo = F(0x181, {0xA0, 0x86, 0x01, 0x00, 0x00});
  EXPECT_EQ(to_string(bus.take()), expected(t0, {{0, pdo}, {ms(1000), pdo}, {ms(2000), pdo}}));
}

TEST_F(Trace, StartAllNodesIsAnsweredToo) {
  boot();
  auto out = nmt(0x01, 0x00);
  EXPECT_EQ(to_string(out), expected(now() - ms(1), {{0, F(0x181, {0xA0, 0x86, 0x01, 0x00, 0x00})}}));
}

// §5.2 draws a stray "0x01" before the pressure bytes (6 fields for DLC 5);
// the §3.5 example is authoritative: int32 pressure LE + status, DLC 5.
TEST_F(Trace, PdoLayoutIsPressureInt32ThenStatus) {
  source->pressure = [](TimeUs) { return 1234567.0; };
  boot();
  auto out = nmt(0x01, 0x01);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(to_string(out[0].frame), to_string(F(0x181, {0x87, 0xD6, 0x12, 0x00, 0x00})));
}

// ---- SDO reads of the measurement (§5.2)

TEST_F(Trace, SdoReadsOfPressureAndTemperature) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x40, 0x30, 0x61, 0x01})),
            expected(t0, {{0, F8(0x581, {0x43, 0x30, 0x61, 0x01, 0x00, 0x50, 0xC3, 0x47})}}));
  EXPECT_EQ(to_string(sdo({0x40, 0x30, 0x91, 0x01})),
            expected(t0 + ms(1), {{0, F8(0x581, {0x43, 0x30, 0x91, 0x01, 0xA0, 0x86, 0x01, 0x00})}}));
  EXPECT_EQ(to_string(sdo({0x40, 0x30, 0x61, 0x02})),
            expected(t0 + ms(2), {{0, F8(0x581, {0x43, 0x30, 0x61, 0x02, 0x00, 0x00, 0xC8, 0x41})}}));
  EXPECT_EQ(to_string(sdo({0x40, 0x30, 0x91, 0x02})),
            expected(t0 + ms(3), {{0, F8(0x581, {0x43, 0x30, 0x91, 0x02, 0x19, 0x00, 0x00, 0x00})}}));
}

// ---- cyclic sending (§5.3)

TEST_F(Trace, ActivateSetAndGetEventTimer) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x2F, 0x00, 0x18, 0x02, 0xFF})), expected(t0, {{0, F8(0x581, {0x60, 0x00, 0x18, 0x02})}}));
  EXPECT_EQ(to_string(sdo({0x40, 0x00, 0x18, 0x05})),
            expected(t0 + ms(1), {{0, F8(0x581, {0x4B, 0x00, 0x18, 0x05, 0xE8, 0x03})}}));
  EXPECT_EQ(to_string(sdo({0x2B, 0x00, 0x18, 0x05, 0xF4, 0x01})),
            expected(t0 + ms(2), {{0, F8(0x581, {0x60, 0x00, 0x18, 0x05})}}));
  EXPECT_EQ(to_string(sdo({0x40, 0x00, 0x18, 0x05})),
            expected(t0 + ms(3), {{0, F8(0x581, {0x4B, 0x00, 0x18, 0x05, 0xF4, 0x01})}}));
}

// ---- node configuration (§5.4)

TEST_F(Trace, SetAndGetNodeId) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x2F, 0x01, 0x4F, 0x00, 0x05})), expected(t0, {{0, F8(0x581, {0x60, 0x01, 0x4F, 0x00})}}));
  // The manual prints 0x60 as the answer's command byte; a 1-byte expedited
  // upload response is 0x4F (as in its own "Get CAN Bitrate index").
  EXPECT_EQ(to_string(sdo({0x40, 0x01, 0x4F, 0x00})),
            expected(t0 + ms(1), {{0, F8(0x581, {0x4F, 0x01, 0x4F, 0x00, 0x05})}}));
}

TEST_F(Trace, SetAndGetBitRateIndex) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x40, 0x00, 0x4F, 0x00})), expected(t0, {{0, F8(0x581, {0x4F, 0x00, 0x4F, 0x00, 0x04})}}));
  // The manual's answer shows index LSB 0x01; the server echoes the request's 0x4F00.
  EXPECT_EQ(to_string(sdo({0x2F, 0x00, 0x4F, 0x00, 0x03})),
            expected(t0 + ms(1), {{0, F8(0x581, {0x60, 0x00, 0x4F, 0x00})}}));
  EXPECT_EQ(to_string(sdo({0x40, 0x00, 0x4F, 0x00})),
            expected(t0 + ms(2), {{0, F8(0x581, {0x4F, 0x00, 0x4F, 0x00, 0x03})}}));
}

TEST_F(Trace, NmtStartupSelfStartingOnAndOff) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x23, 0x80, 0x1F, 0x00, 0x08, 0x00, 0x00, 0x00})),
            expected(t0, {{0, F8(0x581, {0x60, 0x80, 0x1F, 0x00})}}));
  EXPECT_EQ(upload(0x1F80, 0), 8u);
  EXPECT_EQ(to_string(sdo({0x23, 0x80, 0x1F, 0x00, 0x04, 0x00, 0x00, 0x00})),
            expected(t0 + ms(2), {{0, F8(0x581, {0x60, 0x80, 0x1F, 0x00})}}));
  EXPECT_EQ(upload(0x1F80, 0), 4u);
}

// The manual labels 0x23 "SDO Request" and 0x6C ASCII 'i': both are an
// expedited 4-byte download of "save" / "load".
TEST_F(Trace, SaveAndLoadCommands) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65})),
            expected(t0, {{0, F8(0x581, {0x60, 0x10, 0x10, 0x01})}}));
  EXPECT_EQ(to_string(sdo({0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64})),
            expected(t0 + ms(1), {{0, F8(0x581, {0x60, 0x11, 0x10, 0x01})}}));
  EXPECT_EQ(sim->storage.saves, 2);
}

// ---- EMCY (§3.6): [code LSB, code MSB, 0x1001, 00 x5], DLC 8 (CiA 301)

TEST_F(Trace, EmergencyMessageConstruction) {
  boot();
  bus.take();
  source->pressure_status = physics::kStatusInvalid;
  const TimeUs t0 = now();
  bus.run_for(ms(10));  // the status is supervised every 10 ms (vendor: monitor_period)
  auto out = bus.take();
  ASSERT_EQ(out.size(), 1u) << to_string(out);
  EXPECT_LE(out[0].time, t0 + ms(10));
  EXPECT_EQ(to_string(out[0].frame), to_string(F8(0x081, {0x11, 0xF0, 0x01})));
}

// ---- LSS example (§4.2): node ID 1 -> 5, bit rate -> 250 kbit/s

TEST_F(Trace, LssExampleChangesNodeIdAndBitRate) {
  bus.power_on_all();
  bus.run_for(ms(1));
  EXPECT_EQ(to_string(bus.take()), expected(0, {{0, F(0x701, {0x00})}}));
  EXPECT_TRUE(nmt(0x02, 0x00).empty());    // No.1 NMT stopped
  EXPECT_TRUE(lss({0x04, 0x01}).empty());  // No.2 configuration state
  TimeUs t = now();
  EXPECT_EQ(to_string(lss({0x11, 0x05})), expected(t, {{0, F8(0x7E4, {0x11, 0x00})}}));  // No.3
  t = now();
  EXPECT_EQ(to_string(lss({0x13, 0x00, 0x03})), expected(t, {{0, F8(0x7E4, {0x13, 0x00})}}));  // No.4
  // No.5: the example's answer starts with 0x00; §4.1 defines answer cs 0x17.
  t = now();
  EXPECT_EQ(to_string(lss({0x17})), expected(t, {{0, F8(0x7E4, {0x17, 0x00})}}));
  // No.6 activate, switch_delay 100 ms: boot-up at the new rate with the old
  // node-ID after the two delay periods (CiA 305), NMT stays stopped.
  t = now();
  bus.take();
  bus.inject(F8(0x7E5, {0x15, 0x64, 0x00}));
  node().set_bus_bit_rate(3);  // the master switches its bit rate too
  bus.run_for(ms(300));
  EXPECT_EQ(to_string(bus.take()), expected(t, {{ms(200), F(0x701, {0x00})}}));
  EXPECT_EQ(node().state(), NmtState::kStopped);
  EXPECT_EQ(node().bit_rate_index(), 3);
  // No.7 waiting state: boot-up with the new node-ID, pre-operational.
  t = now();
  EXPECT_EQ(to_string(lss({0x04, 0x00})), expected(t, {{0, F(0x705, {0x00})}}));
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  EXPECT_EQ(upload(0x4F01, 0, 5), 5u);
  EXPECT_EQ(upload(0x4F00, 0, 5), 3u);
}

// ---- LSS templates (§4.1)

TEST_F(Trace, LssSwitchStateGlobalHasNoAnswer) {
  boot();
  nmt(0x02);
  EXPECT_TRUE(lss({0x04, 0x01}).empty());
  EXPECT_TRUE(node().lss().configuring());
  EXPECT_TRUE(lss({0x04, 0x00}).empty());  // nothing stored: no boot-up
  EXPECT_FALSE(node().lss().configuring());
}

TEST_F(Trace, LssSwitchStateSelective) {
  boot();
  nmt(0x02);
  EXPECT_TRUE(lss({0x40, 0x3D, 0x02, 0x00, 0x00}).empty());
  EXPECT_TRUE(lss({0x41, 0x20, 0x09, 0x00, 0x00}).empty());
  EXPECT_TRUE(lss({0x42, 0x00, 0x01, 0x00, 0x00}).empty());
  const TimeUs t = now();
  EXPECT_EQ(to_string(lss({0x43, 0x70, 0x68, 0x03, 0x00})), expected(t, {{0, F8(0x7E4, {0x44})}}));
  EXPECT_TRUE(node().lss().configuring());
}

TEST_F(Trace, LssConfigureNodeIdAndBitTiming) {
  boot();
  nmt(0x02);
  lss({0x04, 0x01});
  TimeUs t = now();
  EXPECT_EQ(to_string(lss({0x11, 0x7F})), expected(t, {{0, F8(0x7E4, {0x11, 0x00})}}));
  t = now();
  EXPECT_EQ(to_string(lss({0x11, 0x80})), expected(t, {{0, F8(0x7E4, {0x11, 0x01})}}));
  for (std::uint8_t idx : {0, 1, 2, 3, 4, 6, 7}) {
    t = now();
    EXPECT_EQ(to_string(lss({0x13, 0x00, idx})), expected(t, {{0, F8(0x7E4, {0x13, 0x00})}})) << int(idx);
  }
  for (std::uint8_t idx : {5, 8, 9}) {
    t = now();
    EXPECT_EQ(to_string(lss({0x13, 0x00, idx})), expected(t, {{0, F8(0x7E4, {0x13, 0x01})}})) << int(idx);
  }
}

// Activate bit timing takes the last *stored* rate: nothing stored -> the
// device boots up again at its current rate after 2 x switch_delay.
TEST_F(Trace, LssActivateBitTimingSendsBootUpAndStaysStopped) {
  boot();
  nmt(0x02);
  lss({0x04, 0x01});
  lss({0x13, 0x00, 0x02});  // pending, not stored
  const TimeUs t = now();
  bus.take();
  bus.inject(F8(0x7E5, {0x15, 0x32, 0x00}));
  bus.run_for(ms(150));
  EXPECT_EQ(to_string(bus.take()), expected(t, {{ms(100), F(0x701, {0x00})}}));
  EXPECT_EQ(node().bit_rate_index(), 4);
  EXPECT_EQ(node().state(), NmtState::kStopped);
}

TEST_F(Trace, LssStoreConfiguration) {
  boot();
  nmt(0x02);
  lss({0x04, 0x01});
  TimeUs t = now();
  EXPECT_EQ(to_string(lss({0x17})), expected(t, {{0, F8(0x7E4, {0x17, 0xFF, 0x01})}}));  // nothing to store
  lss({0x11, 0x09});
  t = now();
  EXPECT_EQ(to_string(lss({0x17})), expected(t, {{0, F8(0x7E4, {0x17, 0x00})}}));
}

// §3.3: 0x4F00 "Changes take effect after reset node or power on"; §4: "Only
// a stored bit rate ... will appear in the object dictionary (0x4F00)". So an
// LSS-stored 250 kbit/s is the rate after NMT reset node: a master still at
// 125 kbit/s hears nothing more (no boot-up, no SDO answer); at 250 it does.
TEST_F(Trace, LssStoredBitRateIsActiveAfterResetNode) {
  boot();
  EXPECT_TRUE(nmt(0x02, 0x00).empty());  // §4: LSS only in NMT stopped
  EXPECT_TRUE(lss({0x04, 0x01}).empty());
  TimeUs t = now();
  EXPECT_EQ(to_string(lss({0x13, 0x00, 0x03})), expected(t, {{0, F8(0x7E4, {0x13, 0x00})}}));
  t = now();
  EXPECT_EQ(to_string(lss({0x17})), expected(t, {{0, F8(0x7E4, {0x17, 0x00})}}));
  EXPECT_TRUE(lss({0x04, 0x00}).empty());  // stored node-ID unchanged: no boot-up
  EXPECT_EQ(node().bit_rate_index(), 4);
  EXPECT_TRUE(nmt(0x81, 0x01, ms(1000)).empty());  // the boot-up goes out at 250 kbit/s
  EXPECT_TRUE(sdo({0x40, 0x00, 0x4F, 0x00}).empty());
  EXPECT_EQ(node().bit_rate_index(), 3);
  node().set_bus_bit_rate(3);  // the master moves to 250 kbit/s
  EXPECT_EQ(upload(0x4F00, 0), 3u);
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
}

TEST_F(Trace, LssInquireAddressAndNodeId) {
  boot();
  nmt(0x02);
  lss({0x04, 0x01});
  TimeUs t = now();
  EXPECT_EQ(to_string(lss({0x5A})), expected(t, {{0, F8(0x7E4, {0x5A, 0x3D, 0x02, 0x00, 0x00})}}));
  t = now();
  EXPECT_EQ(to_string(lss({0x5B})), expected(t, {{0, F8(0x7E4, {0x5B, 0x20, 0x09, 0x00, 0x00})}}));
  t = now();
  EXPECT_EQ(to_string(lss({0x5C})), expected(t, {{0, F8(0x7E4, {0x5C, 0x00, 0x01, 0x00, 0x00})}}));
  t = now();
  EXPECT_EQ(to_string(lss({0x5D})), expected(t, {{0, F8(0x7E4, {0x5D, 0x70, 0x68, 0x03, 0x00})}}));
  t = now();
  EXPECT_EQ(to_string(lss({0x5E})), expected(t, {{0, F8(0x7E4, {0x5E, 0x01})}}));
}

// The manual leaves the "Command specifier answer" line empty and prints 0x4F
// after the request list (layout artefact): 0x4F is the answer.
TEST_F(Trace, LssIdentifyRemoteSlave) {
  boot();
  nmt(0x02);
  EXPECT_TRUE(lss({0x46, 0x3D, 0x02}).empty());
  EXPECT_TRUE(lss({0x47, 0x20, 0x09}).empty());
  EXPECT_TRUE(lss({0x48, 0x00}).empty());
  EXPECT_TRUE(lss({0x49, 0x00, 0x02}).empty());
  EXPECT_TRUE(lss({0x4A, 0x00}).empty());
  const TimeUs t = now();
  EXPECT_EQ(to_string(lss({0x4B, 0xFF, 0xFF, 0xFF, 0x00})), expected(t, {{0, F8(0x7E4, {0x4F})}}));
}

// Only a slave without a valid node-ID answers (CiA 305); this device always has one.
TEST_F(Trace, LssIdentifyNonConfiguredIsNotAnswered) {
  boot();
  nmt(0x02);
  EXPECT_TRUE(lss({0x4C}).empty());
}

// ---- derived: mapping change to float pressure + int32 temperature (§3.5)

TEST_F(Trace, MappingFloatPressureAndIntTemperature) {
  boot();
  nmt(0x01);
  TimeUs t = now();
  EXPECT_EQ(to_string(sdo({0x2F, 0x00, 0x1A, 0x00, 0x00})), expected(t, {{0, F8(0x581, {0x60, 0x00, 0x1A, 0x00})}}));
  t = now();
  EXPECT_EQ(to_string(sdo({0x23, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x30, 0x61})),
            expected(t, {{0, F8(0x581, {0x60, 0x00, 0x1A, 0x01})}}));
  t = now();
  EXPECT_EQ(to_string(sdo({0x23, 0x00, 0x1A, 0x02, 0x20, 0x02, 0x30, 0x91})),
            expected(t, {{0, F8(0x581, {0x60, 0x00, 0x1A, 0x02})}}));
  t = now();
  EXPECT_EQ(to_string(sdo({0x2F, 0x00, 0x1A, 0x00, 0x02})), expected(t, {{0, F8(0x581, {0x60, 0x00, 0x1A, 0x00})}}));
  auto pdos = only(run(ms(1000)), 0x181);
  ASSERT_EQ(pdos.size(), 1u);
  EXPECT_EQ(to_string(pdos[0].frame), to_string(F(0x181, {0x00, 0x50, 0xC3, 0x47, 0x19, 0x00, 0x00, 0x00})));
}

}  // namespace
}  // namespace cansim::test
