// Every frame trace of the SMC spec (§13, from the manual's §4.3, §4.5, §8.2-§8.10)
// replayed against the personality: frames in, exact frames out, at the time the
// trace implies. Placeholders (XX, EE, TT BB, t0/t5, DD CC BB AA) are resolved
// as the spec's data_resolved says; the comments say why where it matters.
#include "smc_support.hpp"

namespace cansim::test {
namespace {

using Trace = SmcFixture;

// §4.3: Start Remote Node to all nodes enables the PDO output (TPDO1 every 100 ms).
TEST_F(Trace, NmtStartAllNodesEnablesPdos) {
  boot();
  const TimeUs t0 = now();
  bus.inject(F(0x000, {0x01, 0x00}));
  bus.run_for(ms(250));
  const CanFrame pdo = F(0x1A0, {0x00, 0x40, 0x1C, 0x46});  // 10000.0 counts = 2.5 bar
  EXPECT_EQ(to_string(bus.take()), expected(t0, {{ms(100), pdo}, {ms(200), pdo}}));
}

// §4.5.1: the figure writes 0x1234:11, which the SMC does not have.
TEST_F(Trace, ExpeditedWriteToAMissingObjectIsAborted) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x23, 0x34, 0x12, 0x11, 1, 2, 3, 4})),
            expected(t0, {{0, F8(0x5A0, {0x80, 0x34, 0x12, 0x11, 0x00, 0x00, 0x02, 0x06})}}));
}

// §4.5.2: device name "Hello World!" (set through 0x4022, the manual's way to
// change 0x1008). CiA 301 framing: t0 = 0x00, t5 = 0x15 (toggle 1, 2 unused, last).
TEST_F(Trace, SegmentedUploadOfTheDeviceName) {
  boot();
  const char* text = "Hello World!";
  for (std::uint8_t k = 0; text[k]; ++k) ASSERT_EQ(download(0x4022, std::uint8_t(k + 1), std::uint8_t(text[k]), 1), 0u);
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x40, 0x08, 0x10, 0x00})),
            expected(t0, {{0, F8(0x5A0, {0x41, 0x08, 0x10, 0x00, 0x0C, 0x00, 0x00, 0x00})}}));
  EXPECT_EQ(to_string(sdo({0x60})),
            expected(t0 + ms(1), {{0, F8(0x5A0, {0x00, 0x48, 0x65, 0x6C, 0x6C, 0x6F, 0x20, 0x57})}}));
  EXPECT_EQ(to_string(sdo({0x70})),
            expected(t0 + ms(2), {{0, F8(0x5A0, {0x15, 0x6F, 0x72, 0x6C, 0x64, 0x21, 0x00, 0x00})}}));
}

// §8.2: boot-up of node 0x20, then silence (heartbeat 0, pre-operational).
TEST_F(Trace, BootUpOn0x720) {
  bus.power_on_all();
  bus.run_for(ms(2000));
  EXPECT_EQ(to_string(bus.take()), expected(0, {{ms(150), F(0x720, {0x00})}}));
}

// §8.2: 0x1000 = 0x80020194 (the OCR's second row is garbled; the text wins).
TEST_F(Trace, ReadDeviceType) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x40, 0x00, 0x10, 0x00})),
            expected(t0, {{0, F8(0x5A0, {0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x80})}}));
}

// §8.3: node-ID via 0x4001:02: no SDO answer, boot-up on the new ID at once
// (boot_up_delay_ms later), COB-IDs re-derived.
TEST_F(Trace, NodeIdViaSdoSub2) {
  boot();
  const TimeUs t0 = now();
  bus.inject(F8(0x620, {0x2F, 0x01, 0x40, 0x02, 0x21}));
  bus.run_for(ms(200));
  EXPECT_EQ(to_string(bus.take()), expected(t0, {{ms(150), F(0x721, {0x00})}}));
  EXPECT_EQ(upload(0x1800, 1, 0x21), 0x400001A1u);
}

// §8.3: node-ID via LSS; active after NMT Reset Node (addressed to the OLD ID).
TEST_F(Trace, NodeIdViaLss) {
  boot();
  const TimeUs t0 = now();
  EXPECT_TRUE(lss({0x04, 0x01}).empty());
  EXPECT_EQ(to_string(lss({0x5E})), expected(t0 + ms(1), {{0, F8(0x7E4, {0x5E, 0x20})}}));
  EXPECT_EQ(to_string(lss({0x11, 0x21})), expected(t0 + ms(2), {{0, F8(0x7E4, {0x11, 0x00})}}));
  EXPECT_EQ(to_string(lss({0x17})), expected(t0 + ms(3), {{0, F8(0x7E4, {0x17, 0x00})}}));
  EXPECT_EQ(to_string(nmt(0x81, 0x20, ms(200))), expected(t0 + ms(4), {{ms(150), F(0x721, {0x00})}}));
}

// §8.4: bit rate via LSS (03 = 250 kbit/s), active after Reset Node: the
// node then runs at 250 kbit/s and is deaf and mute on the 125 kbit/s bus.
TEST_F(Trace, BitRateViaLss) {
  boot();
  const TimeUs t0 = now();
  EXPECT_TRUE(lss({0x04, 0x01}).empty());
  EXPECT_EQ(to_string(lss({0x5E})), expected(t0 + ms(1), {{0, F8(0x7E4, {0x5E, 0x20})}}));
  EXPECT_EQ(to_string(lss({0x13, 0x00, 0x03})), expected(t0 + ms(2), {{0, F8(0x7E4, {0x13, 0x00})}}));
  EXPECT_EQ(to_string(lss({0x17})), expected(t0 + ms(3), {{0, F8(0x7E4, {0x17, 0x00})}}));
  EXPECT_TRUE(nmt(0x81, 0x20, ms(200)).empty());  // boot-up sent at 250 kbit/s
  EXPECT_EQ(node().bit_rate_index(), 3);
  EXPECT_TRUE(sdo({0x40, 0x00, 0x10, 0x00}).empty());
  node().set_bus_bit_rate(3);
  EXPECT_EQ(upload(0x1000, 0), 0x80020194u);
}

// §8.5: autostart; RAM only until stored.
TEST_F(Trace, EnableAutostart) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x23, 0x80, 0x1F, 0x00, 0x08})), expected(t0, {{0, F8(0x5A0, {0x60, 0x80, 0x1F, 0x00})}}));
}

// §8.6: reads of the measurement. Default scaling: PV = FV counts.
TEST_F(Trace, ReadProcessAndFieldValues) {
  source->fv[0] = 12345;
  source->fv[1] = 8889;
  boot();
  const TimeUs t0 = now();
  // 12345.0 = 0x4640E400
  EXPECT_EQ(to_string(sdo({0x40, 0x30, 0x61, 0x01})),
            expected(t0, {{0, F8(0x5A0, {0x43, 0x30, 0x61, 0x01, 0x00, 0xE4, 0x40, 0x46})}}));
  EXPECT_EQ(to_string(sdo({0x40, 0x30, 0x91, 0x01})),
            expected(t0 + ms(1), {{0, F8(0x5A0, {0x43, 0x30, 0x91, 0x01, 0x39, 0x30, 0x00, 0x00})}}));
  // The manual prints 0x43 for this INTEGER16; its own table says 0x4B (2 bytes).
  EXPECT_EQ(to_string(sdo({0x40, 0x00, 0x71, 0x01})),
            expected(t0 + ms(2), {{0, F8(0x5A0, {0x4B, 0x00, 0x71, 0x01, 0x39, 0x30})}}));
  EXPECT_EQ(to_string(sdo({0x40, 0x30, 0x71, 0x01})),
            expected(t0 + ms(3), {{0, F8(0x5A0, {0x4B, 0x30, 0x71, 0x01, 0x39, 0x30})}}));
  // 8889.0 = 0x460AE400
  EXPECT_EQ(to_string(sdo({0x40, 0x30, 0x61, 0x02})),
            expected(t0 + ms(4), {{0, F8(0x5A0, {0x43, 0x30, 0x61, 0x02, 0x00, 0xE4, 0x0A, 0x46})}}));
}

// §8.7 example 1: the device echoes sub 01 (the printed "02" is a copy/paste).
TEST_F(Trace, ScalingExample1PsiRange) {
  source->fv[0] = 10000;
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x22, 0x21, 0x61, 0x01, 0x00, 0x00, 0x00, 0x00})),
            expected(t0, {{0, F8(0x5A0, {0x60, 0x21, 0x61, 0x01})}}));
  EXPECT_EQ(to_string(sdo({0x22, 0x23, 0x61, 0x01, 0x00, 0x40, 0x9C, 0x45})),
            expected(t0 + ms(1), {{0, F8(0x5A0, {0x60, 0x23, 0x61, 0x01})}}));
  EXPECT_FLOAT_EQ(upload_f(0x6130, 1), 2500.0f);  // p[PSI] = FV / 4
}

// §8.7 example 2: temperature channel -55..125 degC.
TEST_F(Trace, ScalingExample2Temperature) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x22, 0x21, 0x61, 0x02, 0x00, 0x00, 0x5C, 0xC2})),
            expected(t0, {{0, F8(0x5A0, {0x60, 0x21, 0x61, 0x02})}}));
  EXPECT_EQ(to_string(sdo({0x22, 0x23, 0x61, 0x02, 0x00, 0x00, 0xFA, 0x42})),
            expected(t0 + ms(1), {{0, F8(0x5A0, {0x60, 0x23, 0x61, 0x02})}}));
  EXPECT_EQ(upload(0x6126, 2), 0x3C1374BCu);  // 0.009
  EXPECT_EQ(upload(0x6127, 2), 0xC25C0000u);  // -55.0
}

// §8.8: TPDO1 every 100 ms (type 0xFE, event timer 100 written with 0x22).
TEST_F(Trace, TimerDrivenTpdo) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x22, 0x00, 0x18, 0x02, 0xFE})), expected(t0, {{0, F8(0x5A0, {0x60, 0x00, 0x18, 0x02})}}));
  EXPECT_EQ(to_string(sdo({0x22, 0x00, 0x18, 0x05, 0x64})),
            expected(t0 + ms(1), {{0, F8(0x5A0, {0x60, 0x00, 0x18, 0x05})}}));
  const TimeUs t1 = now();
  bus.inject(F(0x000, {0x01, 0x20}));
  bus.run_for(ms(310));
  const CanFrame pdo = F(0x1A0, {0x00, 0x40, 0x1C, 0x46});
  EXPECT_EQ(to_string(bus.take()), expected(t1, {{ms(100), pdo}, {ms(200), pdo}, {ms(300), pdo}}));
}

// §8.8: TPDO1 on every 10th SYNC, Operational only.
TEST_F(Trace, SyncDrivenTpdo) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x22, 0x00, 0x18, 0x02, 0x0A})), expected(t0, {{0, F8(0x5A0, {0x60, 0x00, 0x18, 0x02})}}));
  nmt(0x01, 0x20);
  bus.take();
  std::vector<Sent> pdos;
  for (int i = 1; i <= 20; ++i) {
    auto out = send(F(0x080, {}));
    for (const Sent& s : out) pdos.push_back(s);
    EXPECT_EQ(out.size(), i % 10 == 0 ? 1u : 0u) << "SYNC " << i;
  }
  ASSERT_EQ(pdos.size(), 2u);
  EXPECT_EQ(to_string(pdos[0].frame), to_string(F(0x1A0, {0x00, 0x40, 0x1C, 0x46})));
}

// §8.8: TPDO1 on a measuring event, PV leaving [1495.2 .. 5010.9]. The manual
// prints no SDO responses; the expected ones are the CiA 301 confirmations.
TEST_F(Trace, MeasuringEventTpdo) {
  source->fv[0] = 3000;
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x22, 0x00, 0x18, 0x02, 0xFF})), expected(t0, {{0, F8(0x5A0, {0x60, 0x00, 0x18, 0x02})}}));
  EXPECT_EQ(to_string(sdo({0x22, 0x00, 0x18, 0x05, 0x00})),
            expected(t0 + ms(1), {{0, F8(0x5A0, {0x60, 0x00, 0x18, 0x05})}}));
  EXPECT_EQ(to_string(sdo({0x22, 0x34, 0x61, 0x01, 0x66, 0xE6, 0xBA, 0x44})),
            expected(t0 + ms(2), {{0, F8(0x5A0, {0x60, 0x34, 0x61, 0x01})}}));
  EXPECT_EQ(to_string(sdo({0x22, 0x35, 0x61, 0x01, 0x33, 0x97, 0x9C, 0x45})),
            expected(t0 + ms(3), {{0, F8(0x5A0, {0x60, 0x35, 0x61, 0x01})}}));
  nmt(0x01, 0x20);
  EXPECT_TRUE(run(ms(100)).empty());  // inside the limits: nothing
  source->fv[0] = 5100;               // above 5010.9
  auto out = run(ms(100));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(to_string(out[0].frame), to_string(F(0x1A0, {0x00, 0x60, 0x9F, 0x45})));  // 5100.0
}

// §8.9: store; §8.10: restore (active at once and persisted).
TEST_F(Trace, StoreAndRestore) {
  boot();
  const TimeUs t0 = now();
  EXPECT_EQ(to_string(sdo({0x22, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65})),
            expected(t0, {{0, F8(0x5A0, {0x60, 0x10, 0x10, 0x01})}}));
  EXPECT_EQ(to_string(sdo({0x22, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64})),
            expected(t0 + ms(1), {{0, F8(0x5A0, {0x60, 0x11, 0x10, 0x01})}}));
}

}  // namespace
}  // namespace cansim::test
