// The SMC spec's top-15 acceptance checks (§15), one test each. Setup: factory
// state, node-ID 0x20, 125 kbit/s, 0..5 bar device, default scaling (PV = FV
// counts), constant values, no noise (SmcSource).
#include <cstring>

#include "smc_support.hpp"

namespace cansim::test {
namespace {

using Acceptance = SmcFixture;

// 1. Boot-up and pre-operational silence.
TEST_F(Acceptance, BootUpThenSilence) {
  bus.power_on_all();
  bus.run_for(ms(200));
  EXPECT_EQ(to_string(bus.take()), expected(0, {{ms(150), F(0x720, {0x00})}}));
  EXPECT_TRUE(run(ms(2000)).empty());
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
}

// 2. Device type, identity, user serial number = 0x1018:04 = LSS serial.
TEST_F(Acceptance, DeviceTypeAndIdentity) {
  boot();
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x00, 0x10, 0x00}), 0x5A0)),
            to_string(F8(0x5A0, {0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x80})));
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x18, 0x10, 0x00}), 0x5A0)),
            to_string(F8(0x5A0, {0x4F, 0x18, 0x10, 0x00, 0x04})));
  EXPECT_EQ(to_string(answer(sdo({0x23, 0x30, 0x40, 0x01, 0x78, 0x56, 0x34, 0x12}), 0x5A0)),
            to_string(F8(0x5A0, {0x60, 0x30, 0x40, 0x01})));
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x18, 0x10, 0x04}), 0x5A0)),
            to_string(F8(0x5A0, {0x43, 0x18, 0x10, 0x04, 0x78, 0x56, 0x34, 0x12})));
  EXPECT_EQ(upload(0x4030, 2), 0u);
  EXPECT_TRUE(lss({0x04, 0x01}).empty());
  EXPECT_EQ(to_string(answer(lss({0x5D}), 0x7E4)), to_string(F8(0x7E4, {0x5D, 0x78, 0x56, 0x34, 0x12})));
}

// 3. Segmented upload framing (CiA 301), toggle error, 0x100A "v1826".
TEST_F(Acceptance, SegmentedUploadFraming) {
  boot();
  const char* text = "Hello World!";
  for (std::uint8_t k = 0; text[k]; ++k) ASSERT_EQ(download(0x4022, std::uint8_t(k + 1), std::uint8_t(text[k]), 1), 0u);
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x08, 0x10, 0x00}), 0x5A0)),
            to_string(F8(0x5A0, {0x41, 0x08, 0x10, 0x00, 0x0C})));
  EXPECT_EQ(to_string(answer(sdo({0x60}), 0x5A0)),
            to_string(F8(0x5A0, {0x00, 0x48, 0x65, 0x6C, 0x6C, 0x6F, 0x20, 0x57})));
  EXPECT_EQ(to_string(answer(sdo({0x70}), 0x5A0)),
            to_string(F8(0x5A0, {0x15, 0x6F, 0x72, 0x6C, 0x64, 0x21, 0x00, 0x00})));
  // 0x60 twice in a row: toggle not alternated
  sdo({0x40, 0x08, 0x10, 0x00});
  sdo({0x60});
  EXPECT_EQ(to_string(answer(sdo({0x60}), 0x5A0)),
            to_string(F8(0x5A0, {0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x03, 0x05})));
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x0A, 0x10, 0x00}), 0x5A0)),
            to_string(F8(0x5A0, {0x41, 0x0A, 0x10, 0x00, 0x05})));
  EXPECT_EQ(to_string(answer(sdo({0x60}), 0x5A0)),
            to_string(F8(0x5A0, {0x05, 0x76, 0x31, 0x38, 0x32, 0x36, 0x00, 0x00})));
}

// 4. NMT start / stop / pre-operational and the default TPDO1.
TEST_F(Acceptance, NmtAndDefaultTpdo1) {
  boot();
  EXPECT_EQ(upload(0x1801, 1), 0xC00002A0u);
  const TimeUs t0 = now();
  bus.inject(F(0x000, {0x01, 0x00}));
  bus.run_for(ms(350));
  auto out = bus.take();
  const CanFrame pdo = F(0x1A0, {0x00, 0x40, 0x1C, 0x46});  // 2.5 bar -> 10000.0
  EXPECT_EQ(to_string(out), expected(t0, {{ms(100), pdo}, {ms(200), pdo}, {ms(300), pdo}}));
  nmt(0x80, 0x20);
  EXPECT_TRUE(run(ms(300)).empty());
  EXPECT_EQ(upload(0x1000, 0), 0x80020194u);
  nmt(0x02, 0x20);
  EXPECT_TRUE(sdo({0x40, 0x00, 0x10, 0x00}).empty());
  nmt(0x01, 0x21);  // another node: no effect
  EXPECT_TRUE(run(ms(300)).empty());
  nmt(0x01, 0x20);
  EXPECT_EQ(only(run(ms(250)), 0x1A0).size(), 2u);
}

// 5. Heartbeat producer and consumer (EMCY 0x8130, 0x1029:01 = 0 -> pre-op).
TEST_F(Acceptance, HeartbeatProducerAndConsumer) {
  boot();
  const TimeUs t0 = now();  // the period starts with the write
  EXPECT_EQ(to_string(answer(sdo({0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03}), 0x5A0)),
            to_string(F8(0x5A0, {0x60, 0x17, 0x10, 0x00})));
  bus.run_for(ms(2099));
  EXPECT_EQ(to_string(bus.take()), expected(t0, {{ms(1000), F(0x720, {0x7F})}, {ms(2000), F(0x720, {0x7F})}}));
  nmt(0x01, 0x20);
  EXPECT_EQ(to_string(only(run(ms(1000)), 0x720)), expected(t0, {{ms(3000), F(0x720, {0x05})}}));
  ASSERT_EQ(download(0x1016, 1, 0x00050064, 4), 0u);
  send(F(0x705, {0x05}));
  auto out = run(ms(150));
  auto emcy = only(out, 0x0A0);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(to_string(emcy[0].frame), to_string(F8(0x0A0, {0x30, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00})));
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  EXPECT_EQ(to_string(only(run(ms(1000)), 0x720).at(0).frame), to_string(F(0x720, {0x7F})));
  nmt(0x02, 0x20);
  EXPECT_EQ(to_string(only(run(ms(1000)), 0x720).at(0).frame), to_string(F(0x720, {0x04})));
}

// 6. Timer-driven TPDO (§8.8); event timer 0 with type 0xFE stops it.
TEST_F(Acceptance, TimerDrivenTpdo) {
  boot();
  EXPECT_EQ(to_string(answer(sdo({0x22, 0x00, 0x18, 0x02, 0xFE}), 0x5A0)),
            to_string(F8(0x5A0, {0x60, 0x00, 0x18, 0x02})));
  EXPECT_EQ(to_string(answer(sdo({0x22, 0x00, 0x18, 0x05, 0x64}), 0x5A0)),
            to_string(F8(0x5A0, {0x60, 0x00, 0x18, 0x05})));
  nmt(0x01, 0x20);
  auto pdos = only(run(ms(1000)), 0x1A0);
  ASSERT_EQ(pdos.size(), 10u);
  for (std::size_t i = 1; i < pdos.size(); ++i) EXPECT_EQ(pdos[i].time - pdos[i - 1].time, ms(100));
  ASSERT_EQ(download(0x1800, 5, 0, 2), 0u);
  EXPECT_TRUE(only(run(ms(500)), 0x1A0).empty());
}

// 7. SYNC-driven TPDO: type 10, 30 SYNCs -> 3 TPDOs right after SYNC 10/20/30; none in pre-op.
TEST_F(Acceptance, SyncDrivenTpdo) {
  boot();
  ASSERT_EQ(download(0x1800, 2, 10, 1), 0u);
  ASSERT_EQ(download(0x1800, 5, 0, 2), 0u);
  for (int i = 0; i < 30; ++i) EXPECT_TRUE(send(F(0x080, {})).empty());
  nmt(0x01, 0x20);
  for (int i = 1; i <= 30; ++i) {
    const TimeUs t = now();
    auto out = send(F(0x080, {}), ms(5));
    if (i % 10 == 0) {
      ASSERT_EQ(out.size(), 1u) << "SYNC " << i;
      EXPECT_EQ(out[0].frame.id, 0x1A0u);
      EXPECT_LE(out[0].time - t, ms(5));
    } else {
      EXPECT_TRUE(out.empty()) << "SYNC " << i;
    }
  }
}

// 8. Measuring events: limits with 1 % hysteresis of the span, and delta.
TEST_F(Acceptance, MeasuringEventsWithHysteresis) {
  source->fv[0] = 12000;  // PV 3000 after scaling below
  boot();
  ASSERT_EQ(download(0x1800, 2, 0xFF, 1), 0u);
  ASSERT_EQ(download(0x1800, 5, 0, 2), 0u);
  ASSERT_EQ(download_f(0x6121, 1, 0.0f), 0u);
  ASSERT_EQ(download_f(0x6123, 1, 5000.0f), 0u);      // PV = FV / 4, hysteresis 50
  ASSERT_EQ(download(0x6134, 1, 0x44BAE666, 4), 0u);  // 1495.2
  ASSERT_EQ(download(0x6135, 1, 0x459C9733, 4), 0u);  // 5010.9
  nmt(0x01, 0x20);
  auto at = [&](double pv) {
    source->fv[0] = pv * 4;
    return only(run(ms(20)), 0x1A0).size();
  };
  EXPECT_EQ(at(3000), 0u);
  std::size_t n = 0;
  for (double pv = 3000; pv <= 5100; pv += 100) n += at(pv);
  EXPECT_EQ(n, 1u);
  EXPECT_EQ(at(5100), 0u);
  EXPECT_EQ(at(4980), 0u);  // not <= 4960.9: still disarmed
  EXPECT_EQ(at(5100), 0u);
  EXPECT_EQ(at(4950), 0u);
  EXPECT_EQ(at(5100), 1u);
  EXPECT_EQ(at(3000), 0u);
  EXPECT_EQ(at(1400), 1u);
  EXPECT_EQ(at(1530), 0u);  // not >= 1545.2
  EXPECT_EQ(at(1400), 0u);
  EXPECT_EQ(at(1600), 0u);
  EXPECT_EQ(at(1400), 1u);
  // delta: a TPDO on every change > 100.0 since the last one
  EXPECT_EQ(at(3000), 0u);
  ASSERT_EQ(download_f(0x6133, 1, 100.0f), 0u);
  EXPECT_EQ(at(3000), 0u);
  EXPECT_EQ(at(3050), 0u);
  EXPECT_EQ(at(3150), 1u);
  EXPECT_EQ(at(3200), 0u);
  EXPECT_EQ(at(3260), 1u);
}

// 9. Mapping procedure (§6.1.19).
TEST_F(Acceptance, MappingProcedure) {
  source->fv[0] = 0x1234;
  boot();
  EXPECT_EQ(download(0x1A00, 1, 0x71000110, 4), 0x08000022u);
  EXPECT_EQ(download(0x1A00, 0, 0, 1), 0u);
  EXPECT_EQ(download(0x1A00, 1, 0x71000110, 4), 0u);
  EXPECT_EQ(download(0x1A00, 2, 0x61500108, 4), 0u);
  EXPECT_EQ(download(0x1A00, 3, 0x10010008, 4), 0u);
  EXPECT_EQ(download(0x1A00, 0, 3, 1), 0u);
  nmt(0x01, 0x20);
  auto pdos = only(run(ms(110)), 0x1A0);
  ASSERT_EQ(pdos.size(), 1u);
  EXPECT_EQ(to_string(pdos[0].frame), to_string(F(0x1A0, {0x34, 0x12, 0x00, 0x00})));
  nmt(0x80, 0x20);
  EXPECT_EQ(download(0x1A00, 0, 0, 1), 0u);
  EXPECT_EQ(download(0x1A00, 1, 0x61310120, 4), 0x06040041u);
  EXPECT_EQ(download(0x1A00, 0, 9, 1), 0x06090030u);
  EXPECT_EQ(download(0x1A00, 1, 0x61300120, 4), 0u);
  EXPECT_EQ(download(0x1A00, 2, 0x61300220, 4), 0u);
  EXPECT_EQ(download(0x1A00, 3, 0x91300120, 4), 0u);
  EXPECT_EQ(download(0x1A00, 0, 3, 1), 0x06040042u);
}

// 10. Store / autostart / restore (§8.5, §8.9, §8.10).
TEST_F(Acceptance, StoreAutostartRestore) {
  boot();
  EXPECT_EQ(to_string(answer(sdo({0x23, 0x80, 0x1F, 0x00, 0x08}), 0x5A0)),
            to_string(F8(0x5A0, {0x60, 0x80, 0x1F, 0x00})));
  power_cycle();
  EXPECT_TRUE(only(run(ms(500)), 0x1A0).empty());
  ASSERT_EQ(download(0x1F80, 0, 8, 4), 0u);
  EXPECT_EQ(to_string(answer(sdo({0x22, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65}), 0x5A0)),
            to_string(F8(0x5A0, {0x60, 0x10, 0x10, 0x01})));
  sim->replace(kId);
  bus.take();
  node().power_on(now());
  auto out = run(ms(400));
  ASSERT_GE(out.size(), 2u);
  EXPECT_EQ(to_string(out[0].frame), to_string(F(0x720, {0x00})));
  EXPECT_EQ(out[1].frame.id, 0x1A0u);
  EXPECT_EQ(to_string(answer(sdo({0x22, 0x10, 0x10, 0x01, 0, 0, 0, 0}), 0x5A0)),
            to_string(F8(0x5A0, {0x80, 0x10, 0x10, 0x01, 0x20, 0x00, 0x00, 0x08})));
  EXPECT_EQ(to_string(answer(sdo({0x22, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64}), 0x5A0)),
            to_string(F8(0x5A0, {0x60, 0x11, 0x10, 0x01})));
  EXPECT_EQ(upload(0x1F80, 0), 0u);
  power_cycle();
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  EXPECT_EQ(node().node_id(), 0x20);
  EXPECT_EQ(node().bit_rate_index(), 4);
}

// 11. Node-ID via 0x4001 sub 2 (COB-IDs re-derived) and sub 1 (COB-IDs kept).
TEST_F(Acceptance, NodeIdVia4001) {
  boot();
  auto out = sdo({0x2F, 0x01, 0x40, 0x02, 0x21}, kId);
  out = run(ms(200));
  EXPECT_TRUE(only(out, 0x5A0).empty());
  EXPECT_EQ(to_string(only(out, 0x721).at(0).frame), to_string(F(0x721, {0x00})));
  EXPECT_EQ(upload(0x1800, 1, 0x21), 0x400001A1u);
  EXPECT_EQ(upload(0x1801, 1, 0x21), 0xC00002A1u);
  EXPECT_EQ(upload(0x1014, 0, 0x21), 0x000000A1u);
  EXPECT_EQ(upload(0x1005, 0, 0x21), 0x00000080u);
  EXPECT_EQ(upload(0x1012, 0, 0x21) & 0x7FF, 0x100u);
  EXPECT_TRUE(sdo({0x40, 0x00, 0x10, 0x00}, kId).empty());
}

TEST_F(Acceptance, NodeIdVia4001Sub1KeepsCobIds) {
  boot();
  EXPECT_EQ(download(0x4001, 1, 0x80, 1), 0x06090030u);
  EXPECT_EQ(node().node_id(), 0x20);
  sdo({0x2F, 0x01, 0x40, 0x01, 0x21});
  auto out = run(ms(200));
  EXPECT_EQ(to_string(only(out, 0x721).at(0).frame), to_string(F(0x721, {0x00})));
  EXPECT_EQ(upload(0x1800, 1, 0x21), 0x400001A0u);
  EXPECT_EQ(upload(0x1014, 0, 0x21), 0x000000A0u);
}

// 12. LSS node-ID and bit rate (§8.3 / §8.4).
TEST_F(Acceptance, LssNodeIdAndBitRate) {
  boot();
  EXPECT_TRUE(lss({0x5E}).empty());  // waiting state: no answer
  lss({0x04, 0x01});
  EXPECT_EQ(to_string(answer(lss({0x5E}), 0x7E4)), to_string(F8(0x7E4, {0x5E, 0x20})));
  EXPECT_EQ(to_string(answer(lss({0x13, 0x00, 0x04}), 0x7E4)), to_string(F8(0x7E4, {0x13, 0x00})));
  EXPECT_EQ(to_string(answer(lss({0x13, 0x00, 0x08}), 0x7E4)), to_string(F8(0x7E4, {0x13, 0x01})));
  EXPECT_EQ(to_string(answer(lss({0x13, 0x01, 0x00}), 0x7E4)), to_string(F8(0x7E4, {0x13, 0x01})));
  EXPECT_EQ(to_string(answer(lss({0x11, 0x00}), 0x7E4)), to_string(F8(0x7E4, {0x11, 0x01})));
  EXPECT_EQ(to_string(answer(lss({0x11, 0x80}), 0x7E4)), to_string(F8(0x7E4, {0x11, 0x01})));
  EXPECT_EQ(to_string(answer(lss({0x11, 0x21}), 0x7E4)), to_string(F8(0x7E4, {0x11, 0x00})));
  EXPECT_EQ(to_string(answer(lss({0x17}), 0x7E4)), to_string(F8(0x7E4, {0x17, 0x00})));
  EXPECT_EQ(upload(0x1000, 0, 0x20), 0x80020194u);  // still the old ID until the reset
  auto out = nmt(0x81, 0x20, ms(200));
  EXPECT_EQ(to_string(out), expected(now() - ms(200), {{ms(150), F(0x721, {0x00})}}));
  EXPECT_EQ(upload(0x1800, 1, 0x21), 0x400001A0u);
}

// 13. Scaling (§8.7 example 2) and the temperature channel.
TEST_F(Acceptance, ScalingAndTemperatureChannel) {
  boot();
  EXPECT_NEAR(upload_f(0x6130, 2), 8889.0f, 1.0f);
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x00, 0x71, 0x02}), 0x5A0)),
            to_string(F8(0x5A0, {0x4B, 0x00, 0x71, 0x02, 0xB9, 0x22})));
  EXPECT_EQ(to_string(answer(sdo({0x22, 0x21, 0x61, 0x02, 0x00, 0x00, 0x5C, 0xC2}), 0x5A0)),
            to_string(F8(0x5A0, {0x60, 0x21, 0x61, 0x02})));
  EXPECT_EQ(to_string(answer(sdo({0x22, 0x23, 0x61, 0x02, 0x00, 0x00, 0xFA, 0x42}), 0x5A0)),
            to_string(F8(0x5A0, {0x60, 0x23, 0x61, 0x02})));
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x26, 0x61, 0x02}), 0x5A0)),
            to_string(F8(0x5A0, {0x43, 0x26, 0x61, 0x02, 0xBC, 0x74, 0x13, 0x3C})));
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x27, 0x61, 0x02}), 0x5A0)),
            to_string(F8(0x5A0, {0x43, 0x27, 0x61, 0x02, 0x00, 0x00, 0x5C, 0xC2})));
  EXPECT_NEAR(upload_f(0x6130, 2), 25.0f, 0.01f);
  EXPECT_EQ(upload(0x7100, 2) & 0xFFFF, 8889u);
  // gain written after the offset: PV2 = offset + gain x 20000
  ASSERT_EQ(download_f(0x6127, 1, 0.0f), 0u);
  ASSERT_EQ(download_f(0x6126, 1, 0.25f), 0u);
  EXPECT_FLOAT_EQ(upload_f(0x6123, 1), 5000.0f);
}

// 14. Decimal digits, integer views, endianness, clamping.
TEST_F(Acceptance, DigitsIntegerViewsEndiannessClamping) {
  source->fv[0] = 192;
  boot();
  ASSERT_EQ(download_f(0x6123, 1, 200.0f), 0u);  // gain 0.01 -> PV 1.92
  ASSERT_EQ(download(0x6132, 1, 2, 1), 0u);
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x30, 0x71, 0x01}), 0x5A0)),
            to_string(F8(0x5A0, {0x4B, 0x30, 0x71, 0x01, 0xC0, 0x00})));
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x30, 0x91, 0x01}), 0x5A0)),
            to_string(F8(0x5A0, {0x43, 0x30, 0x91, 0x01, 0xC0, 0x00, 0x00, 0x00})));
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x30, 0x61, 0x01}), 0x5A0)),
            to_string(F8(0x5A0, {0x43, 0x30, 0x61, 0x01, 0x8F, 0xC2, 0xF5, 0x3F})));
  ASSERT_EQ(download(0x4000, 0, 1, 1), 0u);
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x30, 0x61, 0x01}), 0x5A0)),
            to_string(F8(0x5A0, {0x43, 0x30, 0x61, 0x01, 0x3F, 0xF5, 0xC2, 0x8F})));
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x30, 0x71, 0x01}), 0x5A0)),
            to_string(F8(0x5A0, {0x4B, 0x30, 0x71, 0x01, 0x00, 0xC0})));
  // Two readers at one instant (e.g. two TPDOs on one SYNC) both get big-endian.
  for (int i = 0; i < 2; ++i) {
    std::span<const std::uint8_t> out;
    ASSERT_EQ(node().read(0x6130, 1, now(), out), SdoAbort::kNone);
    EXPECT_EQ(std::vector<std::uint8_t>(out.begin(), out.end()), (std::vector<std::uint8_t>{0x3F, 0xF5, 0xC2, 0x8F}));
  }
  EXPECT_EQ(upload(0x1001, 0), 0u);
  EXPECT_EQ(upload(0x6150, 1), 0u);
  nmt(0x01, 0x20);
  auto pdos = only(run(ms(110)), 0x1A0);
  ASSERT_EQ(pdos.size(), 1u);
  EXPECT_EQ(to_string(pdos[0].frame), to_string(F(0x1A0, {0x3F, 0xF5, 0xC2, 0x8F})));
  EXPECT_EQ(download(0x6132, 1, 10, 1), 0x06090030u);
  ASSERT_EQ(download(0x4000, 0, 0, 1), 0u);
  // clamping
  ASSERT_EQ(download_f(0x3201, 1, 0.0f), 0u);
  ASSERT_EQ(download(0x3125, 1, 0x43C80000, 4), 0u);  // input offset 400 -> PV -2.08
  EXPECT_EQ(upload(0x6130, 1), 0u);
  EXPECT_EQ(upload(0x3200, 1), 1u);
  ASSERT_EQ(download(0x3200, 1, 0, 1), 0u);
  EXPECT_EQ(upload(0x3201, 1), 0xFF7FFFFFu);
  EXPECT_EQ(upload(0x3200, 1), 0u);
}

// 15. Sensor fault EMCY chain (§4.8, §6.1.2, §6.1.17).
TEST_F(Acceptance, SensorFaultEmcyChain) {
  boot();
  ASSERT_EQ(download(0x1017, 0, 1000, 2), 0u);
  nmt(0x01, 0x20);
  run(ms(300));
  source->status[0] = physics::kStatusInvalid;
  auto out = run(ms(20));
  auto emcy = only(out, 0x0A0);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(to_string(emcy[0].frame), to_string(F8(0x0A0, {0x30, 0x50, 0x01, 0x55, 0xC5})));
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  EXPECT_TRUE(only(run(ms(300)), 0x1A0).empty());
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x01, 0x10, 0x00}), 0x5A0)),
            to_string(F8(0x5A0, {0x4F, 0x01, 0x10, 0x00, 0x01})));
  EXPECT_EQ(upload(0x6150, 1) & 1, 1u);
  EXPECT_EQ(upload(0x1002, 0) & 1, 1u);
  EXPECT_EQ(upload(0x1003, 0), 1u);
  EXPECT_EQ(to_string(answer(sdo({0x40, 0x03, 0x10, 0x01}), 0x5A0)),
            to_string(F8(0x5A0, {0x43, 0x03, 0x10, 0x01, 0x30, 0x50, 0x55, 0xC5})));
  EXPECT_EQ(to_string(only(run(ms(1000)), 0x720).at(0).frame), to_string(F(0x720, {0x7F})));
  ASSERT_EQ(download(0x1003, 0, 0, 4), 0u);
  EXPECT_EQ(upload(0x1003, 0), 0u);
  source->status[0] = 0;
  nmt(0x81, 0x20, ms(200));
  EXPECT_EQ(upload(0x1001, 0), 1u);  // latched until power-off
  power_cycle();
  EXPECT_EQ(upload(0x1001, 0), 0u);
  // 0x1029:03 = 2: stopped
  ASSERT_EQ(download(0x1029, 3, 2, 1), 0u);
  source->status[0] = physics::kStatusInvalid;
  run(ms(20));
  EXPECT_EQ(node().state(), NmtState::kStopped);
}

}  // namespace
}  // namespace cansim::test
