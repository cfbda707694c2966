// The P92C spec's top-15 acceptance checks (§14), one test each. Node-ID 1,
// 125 kbit/s, factory defaults; SDO requests to 0x601, answers from 0x581.
#include "p92c_support.hpp"

namespace cansim::test {
namespace {

using Acceptance = P92cFixture;

std::vector<std::uint8_t> bytes(const CanFrame& f) { return {f.data, f.data + f.dlc}; }
using B = std::vector<std::uint8_t>;

// 1. Boot-up [00] first; with 0x1F80 = 4 and 0x1017 = 0 nothing follows for 3 s.
TEST_F(Acceptance, C01_BootUpThenSilence) {
  bus.power_on_all();
  bus.run_for(ms(3000));
  auto out = bus.take();
  ASSERT_EQ(out.size(), 1u) << to_string(out);
  EXPECT_EQ(out[0].time, 0);
  EXPECT_EQ(to_string(out[0].frame), "701 [1] 00");
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
}

// 2. Identity by SDO, 0x1008 segmented.
TEST_F(Acceptance, C02_IdentityBySdo) {
  boot();
  EXPECT_EQ(bytes(answer(sdo({0x40, 0x00, 0x10, 0x00}), 0x581)), (B{0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
  EXPECT_EQ(bytes(answer(sdo({0x40, 0x18, 0x10, 0x01}), 0x581)), (B{0x43, 0x18, 0x10, 0x01, 0x3D, 0x02, 0x00, 0x00}));
  EXPECT_EQ(bytes(answer(sdo({0x40, 0x08, 0x10, 0x00}), 0x581)), (B{0x41, 0x08, 0x10, 0x00, 0x10, 0x00, 0x00, 0x00}));
  EXPECT_EQ(bytes(answer(sdo({0x60}), 0x581)), (B{0x00, 'D', 'S', 'T', ' ', 'P', '9', '2'}));
  EXPECT_EQ(bytes(answer(sdo({0x70}), 0x581)), (B{0x10, 'C', ' ', 'C', 'A', 'N', 'o', 'p'}));
  EXPECT_EQ(bytes(answer(sdo({0x60}), 0x581)), (B{0x0B, 'e', 'n', 0x00, 0x00, 0x00, 0x00, 0x00}));
}

// 3. Start (to the node and to all) -> immediate TPDO, then every 1000 ms; the
// data equals 0x9130:01 and 0x6150:01 at the same pressure.
TEST_F(Acceptance, C03_StartGivesImmediateAndCyclicTpdo) {
  source->pressure = [](TimeUs t) { return 2.0e5 + double(t / 1000); };  // changes every ms
  boot();
  for (std::uint8_t target : {1, 0}) {
    nmt(0x80, 0);  // back to pre-operational
    const TimeUs t0 = now();
    bus.take();
    bus.inject(F(0x000, {0x01, target}));
    bus.run_for(ms(3500));
    auto pdos = only(bus.take(), 0x181);
    ASSERT_EQ(pdos.size(), 4u) << to_string(pdos);
    for (std::size_t i = 0; i < pdos.size(); ++i) {
      EXPECT_EQ(pdos[i].time, t0 + ms(1000) * TimeUs(i));
      EXPECT_EQ(pdos[i].frame.dlc, 5);
      const std::int32_t expected = std::int32_t(2.0e5 + double(pdos[i].time / 1000));
      EXPECT_EQ(std::int32_t(get_u32(pdos[i].frame.data)), expected);
      EXPECT_EQ(pdos[i].frame.data[4], 0);
    }
  }
  // The SDO view of the same instant.
  const std::int32_t pv = std::int32_t(upload(0x9130, 1));
  EXPECT_EQ(pv, std::int32_t(2.0e5 + double((now() - ms(1)) / 1000)));
  EXPECT_EQ(upload(0x6150, 1), 0u);
}

// 4. The manual's PDO example and its bar / decimal digits variants.
TEST_F(Acceptance, C04_ManualPdoExample) {
  boot();
  EXPECT_EQ(to_string(only(nmt(0x01, 1), 0x181)[0].frame), "181 [5] A0 86 01 00 00");
  EXPECT_EQ(download(0x6131, 1, 0x004E0000, 4), 0u);
  EXPECT_EQ(download(0x6132, 1, 5, 1), 0u);
  auto pdos = only(run(ms(1000)), 0x181);
  ASSERT_EQ(pdos.size(), 1u);
  EXPECT_EQ(to_string(pdos[0].frame), "181 [5] A0 86 01 00 00");
  EXPECT_EQ(download(0x6132, 1, 0, 1), 0u);
  pdos = only(run(ms(1000)), 0x181);
  ASSERT_EQ(pdos.size(), 1u);
  EXPECT_EQ(to_string(pdos[0].frame), "181 [5] 01 00 00 00 00");
  EXPECT_EQ(bytes(answer(sdo({0x40, 0x30, 0x61, 0x01}), 0x581)), (B{0x43, 0x30, 0x61, 0x01, 0x00, 0x00, 0x80, 0x3F}));
}

// 5. Decimal digits per unit, unit codes, temperature in degF.
TEST_F(Acceptance, C05_UnitAndDigitLimits) {
  boot();
  EXPECT_EQ(download(0x6132, 1, 1, 1), 0x06090031u);  // Pa: [0]
  EXPECT_EQ(download(0x6131, 1, 0x00AB0000, 4), 0u);  // psi: [0-3]
  EXPECT_EQ(download(0x6132, 1, 3, 1), 0u);
  EXPECT_EQ(download(0x6132, 1, 4, 1), 0x06090031u);
  EXPECT_EQ(download(0x6131, 1, 0x004E0000, 4), 0u);  // bar: [0-5]
  EXPECT_EQ(download(0x6132, 1, 5, 1), 0u);
  EXPECT_EQ(download(0x6132, 1, 6, 1), 0x06090031u);
  EXPECT_EQ(download(0x6131, 1, 0x00030000, 4), 0x06090030u);
  EXPECT_EQ(download(0x6131, 1, 0xFD220000, 4), 0x06090030u);  // no prefix with Pa
  EXPECT_EQ(download(0x6131, 1, 0x00220000, 4), 0x06040043u);  // 5 digits do not fit Pa
  EXPECT_EQ(download(0x6131, 2, 0x00AC0000, 4), 0u);
  EXPECT_EQ(download(0x6132, 2, 1, 1), 0u);
  EXPECT_EQ(upload(0x9130, 2), 770u);
  EXPECT_EQ(download(0x6132, 2, 6, 1), 0x06090031u);
}

// 6. Only transmission types 0x01 and 0xFF.
TEST_F(Acceptance, C06_TransmissionTypeRules) {
  boot();
  EXPECT_EQ(bytes(answer(sdo({0x2F, 0x00, 0x18, 0x02, 0x00}), 0x581)),
            (B{0x80, 0x00, 0x18, 0x02, 0x30, 0x00, 0x09, 0x06}));
  for (std::uint32_t type : {0x02u, 0xF0u, 0xFCu, 0xFDu, 0xFEu}) EXPECT_EQ(download(0x1800, 2, type, 1), 0x06090030u);
  EXPECT_EQ(bytes(answer(sdo({0x2F, 0x00, 0x18, 0x02, 0x01}), 0x581)), (B{0x60, 0x00, 0x18, 0x02, 0, 0, 0, 0}));
  EXPECT_TRUE(only(send(F(0x080, {})), 0x181).empty());  // pre-operational: nothing
  EXPECT_TRUE(only(nmt(0x01, 1), 0x181).empty());        // no immediate PDO with type 1
  EXPECT_TRUE(only(run(ms(2500)), 0x181).empty());       // no cyclic PDO
  for (int i = 0; i < 3; ++i) {
    auto out = send(F(0x080, {}));
    ASSERT_EQ(only(out, 0x181).size(), 1u);
    EXPECT_EQ(only(out, 0x181)[0].time, now() - ms(1));
  }
  EXPECT_EQ(download(0x1800, 2, 0xFF, 1), 0u);
  EXPECT_EQ(only(run(ms(2000)), 0x181).size(), 2u);
}

// 7. Event timer 100 ms, read back, 0 stops.
TEST_F(Acceptance, C07_EventTimer) {
  boot();
  nmt(0x01, 1);
  EXPECT_EQ(bytes(answer(sdo({0x2B, 0x00, 0x18, 0x05, 0x64, 0x00}), 0x581)), (B{0x60, 0x00, 0x18, 0x05, 0, 0, 0, 0}));
  const TimeUs t0 = now() - ms(1);
  auto pdos = only(run(ms(1000)), 0x181);
  ASSERT_GE(pdos.size(), 9u);
  for (std::size_t i = 0; i < pdos.size(); ++i) EXPECT_EQ(pdos[i].time, t0 + ms(100) * TimeUs(i + 1));
  EXPECT_EQ(bytes(answer(sdo({0x40, 0x00, 0x18, 0x05}), 0x581)), (B{0x4B, 0x00, 0x18, 0x05, 0x64, 0x00, 0x00, 0x00}));
  EXPECT_EQ(download(0x1800, 5, 0, 2), 0u);
  EXPECT_TRUE(only(run(ms(3000)), 0x181).empty());
}

// 8. Mapping procedure (§3.5) and its abort codes.
TEST_F(Acceptance, C08_MappingProcedureAndErrors) {
  boot();
  nmt(0x01, 1);
  EXPECT_EQ(download(0x1A00, 1, 0x61300120, 4), 0x06040043u);  // :00 = 2
  EXPECT_EQ(download(0x1A00, 0, 0, 1), 0u);
  EXPECT_TRUE(only(run(ms(2500)), 0x181).empty());  // deactivated
  EXPECT_EQ(download(0x1A00, 1, 0x71000110, 4), 0x06040041u);
  EXPECT_EQ(download(0x1A00, 1, 0x61300120, 4), 0u);
  EXPECT_EQ(download(0x1A00, 2, 0x91300220, 4), 0u);
  EXPECT_EQ(download(0x1A00, 0, 2, 1), 0u);
  auto pdos = only(run(ms(1000)), 0x181);
  ASSERT_EQ(pdos.size(), 1u);
  EXPECT_EQ(to_string(pdos[0].frame), "181 [8] 00 50 C3 47 19 00 00 00");
  EXPECT_EQ(download(0x1A00, 0, 0, 1), 0u);
  EXPECT_EQ(download(0x1A00, 1, 0x91300120, 4), 0u);
  EXPECT_EQ(download(0x1A00, 3, 0x61500108, 4), 0u);
  EXPECT_EQ(download(0x1A00, 0, 3, 1), 0x06040042u);
  EXPECT_EQ(download(0x1A00, 0, 5, 1), 0x06090031u);
  EXPECT_EQ(download(0x1A00, 4, 0x61300120, 4), 0u);
  EXPECT_EQ(download(0x1A00, 0, 4, 1), 0x06040042u);
}

// 9. Save, reset node, restore defaults.
TEST_F(Acceptance, C09_SaveResetRestore) {
  boot();
  EXPECT_EQ(download(0x1800, 5, 500, 2), 0u);
  EXPECT_EQ(bytes(answer(sdo({0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65}), 0x581)),
            (B{0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0}));
  auto boot_up = nmt(0x81, 1);
  EXPECT_EQ(to_string(boot_up), std::to_string(now() - ms(1)) + "us 701 [1] 00\n");
  EXPECT_EQ(upload(0x1800, 5), 500u);
  EXPECT_EQ(bytes(answer(sdo({0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64}), 0x581)),
            (B{0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(upload(0x1800, 5), 500u);
  nmt(0x81, 1);
  EXPECT_EQ(upload(0x1800, 5), 1000u);
  EXPECT_EQ(download(0x1010, 1, 0x65766174, 4), 0x08000020u);
  EXPECT_EQ(download(0x1011, 1, 0x64616F6D, 4), 0x08000020u);
}

// 10. Node-ID by SDO: active after save + reset node.
TEST_F(Acceptance, C10_NodeIdChangeBySdo) {
  boot();
  EXPECT_EQ(bytes(answer(sdo({0x2F, 0x01, 0x4F, 0x00, 0x05}), 0x581)), (B{0x60, 0x01, 0x4F, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(upload(0x1000, 0), 0x00020194u);  // still on 0x601 / 0x581
  EXPECT_EQ(download(0x1010, 1, 0x65766173, 4), 0u);
  auto boot_up = nmt(0x81, 0);
  EXPECT_EQ(to_string(boot_up), std::to_string(now() - ms(1)) + "us 705 [1] 00\n");
  EXPECT_EQ(upload(0x1014, 0, 5), 0x85u);
  EXPECT_TRUE(sdo({0x40, 0x00, 0x10, 0x00}, 1).empty());
  EXPECT_EQ(to_string(only(nmt(0x01, 5), 0x185)[0].frame), "185 [5] A0 86 01 00 00");
  EXPECT_EQ(download(0x4F01, 0, 0, 1, 5), 0x06090032u);
  EXPECT_EQ(download(0x4F01, 0, 128, 1, 5), 0x06090031u);
  EXPECT_EQ(download(0x4F00, 0, 5, 1, 5), 0x06090030u);
  EXPECT_EQ(download(0x4F00, 0, 8, 1, 5), 0x06090030u);
}

// 11. The LSS example end to end, then a power cycle.
TEST_F(Acceptance, C11_LssExampleEndToEnd) {
  boot();
  EXPECT_EQ(download(0x1017, 0, 100, 2), 0u);  // heartbeat shows the NMT state
  nmt(0x02, 0);
  lss({0x04, 0x01});
  EXPECT_EQ(bytes(answer(lss({0x11, 0x05}), 0x7E4)), (B{0x11, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(answer(lss({0x13, 0x00, 0x03}), 0x7E4)), (B{0x13, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(answer(lss({0x17}), 0x7E4)), (B{0x17, 0, 0, 0, 0, 0, 0, 0}));
  const TimeUs t = now();
  bus.take();
  bus.inject(F8(0x7E5, {0x15, 0x64, 0x00}));
  node().set_bus_bit_rate(3);
  bus.run_for(ms(400));
  auto out = bus.take();
  auto boot_ups = only(out, 0x701);
  ASSERT_GE(boot_ups.size(), 2u) << to_string(out);
  EXPECT_EQ(to_string(boot_ups[0].frame), "701 [1] 00");
  EXPECT_EQ(boot_ups[0].time, t + ms(200));
  for (std::size_t i = 1; i < boot_ups.size(); ++i) EXPECT_EQ(to_string(boot_ups[i].frame), "701 [1] 04");
  EXPECT_EQ(node().state(), NmtState::kStopped);
  // The spec expects no SDO answer in STOPPED; the manual (§5.2) says SDO access
  // is "independent of the current operational state" (option sdo_in_stopped).
  EXPECT_EQ(upload(0x4F01, 0), 5u);
  EXPECT_EQ(to_string(only(lss({0x04, 0x00}), 0x705)[0].frame), "705 [1] 00");
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  EXPECT_EQ(upload(0x4F01, 0, 5), 5u);
  EXPECT_EQ(upload(0x4F00, 0, 5), 3u);
  sim->replace(1);  // power cycle, the master stays at 250 kbit/s
  node().set_bus_bit_rate(3);
  bus.take();
  node().power_on(now());
  EXPECT_EQ(node().node_id(), 5);
  EXPECT_EQ(node().bit_rate_index(), 3);
  EXPECT_EQ(to_string(bus.take()), std::to_string(now()) + "us 705 [1] 00\n");
}

// 12. LSS only in NMT stopped, NMT ignored in configuration, vendor error codes.
TEST_F(Acceptance, C12_LssGatingAndQuirks) {
  boot();
  EXPECT_TRUE(lss({0x04, 0x01}).empty());
  EXPECT_TRUE(lss({0x11, 0x05}).empty());  // pre-operational: ignored
  nmt(0x02, 0);
  lss({0x04, 0x01});
  EXPECT_TRUE(nmt(0x81, 0).empty());  // no boot-up
  EXPECT_TRUE(node().lss().configuring());
  EXPECT_EQ(bytes(answer(lss({0x17}), 0x7E4)), (B{0x17, 0xFF, 0x01, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(answer(lss({0x11, 0x00}), 0x7E4)), (B{0x11, 0x01, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(answer(lss({0x11, 0xFF}), 0x7E4)), (B{0x11, 0x01, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(answer(lss({0x13, 0x00, 0x05}), 0x7E4)), (B{0x13, 0x01, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(answer(lss({0x13, 0x01, 0x03}), 0x7E4)), (B{0x13, 0x01, 0, 0, 0, 0, 0, 0}));
}

// 13. Inquire (stored node-ID), switch selective and identify with revision 0.
TEST_F(Acceptance, C13_LssInquireAndSelective) {
  boot();
  nmt(0x02, 0);
  lss({0x04, 0x01});
  EXPECT_EQ(bytes(answer(lss({0x5A}), 0x7E4)), (B{0x5A, 0x3D, 0x02, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(answer(lss({0x5D}), 0x7E4)), (B{0x5D, 0x70, 0x68, 0x03, 0, 0, 0, 0}));
  lss({0x11, 0x07});
  EXPECT_EQ(bytes(answer(lss({0x5E}), 0x7E4)), (B{0x5E, 0x01, 0, 0, 0, 0, 0, 0}));
  lss({0x17});
  EXPECT_EQ(bytes(answer(lss({0x5E}), 0x7E4)), (B{0x5E, 0x07, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(node().node_id(), 1);
  lss({0x04, 0x00});  // activates 7
  EXPECT_EQ(node().node_id(), 7);
  nmt(0x02, 0);
  lss({0x40, 0x3D, 0x02});
  lss({0x41, 0x20, 0x09});
  lss({0x42, 0x00});  // revision 0 = any
  EXPECT_EQ(bytes(answer(lss({0x43, 0x70, 0x68, 0x03}), 0x7E4)), (B{0x44, 0, 0, 0, 0, 0, 0, 0}));
  lss({0x46, 0x3D, 0x02});
  lss({0x47, 0x20, 0x09});
  lss({0x48, 0x00});
  lss({0x49, 0x00});
  lss({0x4A, 0x00, 0x00, 0x03});
  EXPECT_EQ(bytes(answer(lss({0x4B, 0x00, 0x00, 0x04}), 0x7E4)), (B{0x4F, 0, 0, 0, 0, 0, 0, 0}));
}

// 14. EMCY codes, error register, the vendor 0x1003 layout.
TEST_F(Acceptance, C14_EmcyAndErrorField) {
  boot();
  EXPECT_EQ(upload(0x1003, 0), 1u);  // vendor default: 1 entry, the current situation
  EXPECT_EQ(upload(0x1003, 1), 0u);
  source->pressure_status = physics::kStatusInvalid;
  auto emcy = only(run(ms(20)), 0x081);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(to_string(emcy[0].frame), "081 [8] 11 F0 01 00 00 00 00 00");
  EXPECT_EQ(upload(0x6150, 1) & 1, 1u);
  EXPECT_EQ(upload(0x1003, 1), 0x0001F011u);
  EXPECT_EQ(upload(0x1001, 0), 1u);
  source->pressure_status = 0;
  emcy = only(run(ms(20)), 0x081);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(to_string(emcy[0].frame), "081 [8] 00 00 00 00 00 00 00 00");
  EXPECT_EQ(upload(0x1001, 0), 0u);
  EXPECT_EQ(download(0x1003, 0, 0, 1), 0u);
  EXPECT_EQ(download(0x1003, 0, 1, 1), 0x06090030u);
  EXPECT_EQ(abort_of(sdo({0x40, 0x03, 0x10, 0x01})), 0x08000024u);
}

// 14b. Temperature fault: code 0x4000, register bits 0 and 3; overload alone is no error.
TEST_F(Acceptance, C14_TemperatureFault) {
  boot();
  source->temperature = [](TimeUs) { return 500.0; };  // far above the span
  EXPECT_TRUE(only(run(ms(20)), 0x081).empty());
  EXPECT_EQ(upload(0x6150, 2) & 2, 2u);
  source->temperature_status = physics::kStatusInvalid;
  auto emcy = only(run(ms(20)), 0x081);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(to_string(emcy[0].frame), "081 [8] 00 40 09 00 00 00 00 00");
  EXPECT_EQ(upload(0x1003, 1), 0x00094000u);
}

// 15. Self-start, heartbeat, overload counter, SDO access errors.
TEST_F(Acceptance, C15_SelfStartHeartbeatCountersAccessErrors) {
  boot();
  EXPECT_EQ(download(0x1F80, 0, 8, 4), 0u);
  EXPECT_EQ(download(0x1F80, 0, 2, 4), 0x06090030u);
  EXPECT_EQ(download(0x1010, 1, 0x65766173, 4), 0u);
  auto out = nmt(0x81, 1);
  ASSERT_GE(out.size(), 2u);
  EXPECT_EQ(to_string(out[0].frame), "701 [1] 00");
  EXPECT_EQ(out[1].frame.id, 0x181u);
  EXPECT_EQ(node().state(), NmtState::kOperational);

  EXPECT_EQ(download(0x1017, 0, 500, 2), 0u);
  auto hb = only(run(ms(1600)), 0x701);
  ASSERT_EQ(hb.size(), 3u);
  EXPECT_EQ(to_string(hb[0].frame), "701 [1] 05");
  nmt(0x80, 1);
  EXPECT_EQ(to_string(only(run(ms(600)), 0x701).at(0).frame), "701 [1] 7F");
  nmt(0x02, 1);
  EXPECT_EQ(to_string(only(run(ms(600)), 0x701).at(0).frame), "701 [1] 04");
  nmt(0x80, 1);

  const TimeUs t0 = now();
  source->pressure = [t0](TimeUs t) {
    const TimeUs d = t - t0;
    const bool high = (d >= ms(100) && d < ms(200)) || (d >= ms(300) && d < ms(400));
    return high ? 300.0e5 : 1.0e5;
  };
  bus.run_for(ms(150));
  EXPECT_EQ(upload(0x6150, 1) & 2, 2u);
  bus.run_for(ms(350));
  EXPECT_EQ(upload(0x6150, 1) & 2, 0u);
  EXPECT_EQ(upload(0x3000, 0), 2u);
  EXPECT_EQ(upload(0x3001, 0), 0u);

  EXPECT_EQ(bytes(answer(sdo({0x40, 0x25, 0x61, 0x01}), 0x581)), (B{0x80, 0x25, 0x61, 0x01, 0x01, 0x00, 0x01, 0x06}));
  EXPECT_EQ(download(0x1000, 0, 1, 4), 0x06010002u);
  EXPECT_EQ(abort_of(sdo({0x40, 0x00, 0x20, 0x00})), 0x06020000u);
  EXPECT_EQ(abort_of(sdo({0x40, 0x18, 0x10, 0x05})), 0x06090011u);
  EXPECT_EQ(download(0x4F01, 0, 5, 2), 0x06070012u);
}

}  // namespace
}  // namespace cansim::test
