// The spec's acceptance checks (trafag-cmp.md §13): 1-15 plus 16-17 added in
// the public-copy pass. Node 1 unless stated.
#include <cmath>

#include "cmp_support.hpp"

namespace cansim::test {
namespace {

constexpr double kQuantumBar = 10.0 / 8192;  // 13-bit output over 0..10 bar
constexpr TimeUs sec(std::int64_t v) { return v * 1000000; }

std::int16_t le16(const CanFrame& f, int at = 0) { return std::int16_t(f.data[at] | f.data[at + 1] << 8); }

// A table process in bar, values held between points.
std::string steps(std::initializer_list<std::pair<double, double>> points) {
  std::string s = "[{table: {points: [";
  for (auto [t, v] : points) {  // appended piecewise: "[" + std::to_string() gives GCC 12 -O3 a false -Wrestrict
    s += '[';
    s += std::to_string(t);
    s += " s, ";
    s += std::to_string(v);
    s += " bar],";
  }
  s.back() = ']';
  return s + ", interpolation: hold}}]";
}

class CmpAcceptance : public ::testing::Test {
 public:
  void start(const std::function<void(YAML::Node&)>& edit = quiet()) {
    b = std::make_unique<CmpBus>(cmp_profile(edit));
    n1 = &b->add(1);
    b->boot();
  }
  Node& node() { return n1->node(); }
  std::uint64_t od(std::uint16_t i, std::uint8_t s) { return node().values().u(i, s); }
  void ok_write(std::uint16_t i, std::uint8_t s, std::uint32_t v) {
    const CanFrame r = b->download(1, i, s, v);
    ASSERT_EQ(r.data[0], 0x60) << std::hex << i << ":" << int(s) << " abort " << CmpBus::u32(r);
  }
  std::unique_ptr<CmpBus> b;
  SimNode* n1 = nullptr;
};

// 1. Boot-up, then PRE-OPERATIONAL without PDOs (Auto-Start off).
TEST_F(CmpAcceptance, Check01BootUpThenSilentPreOperational) {
  b = std::make_unique<CmpBus>(cmp_profile(quiet()));
  n1 = &b->add(1);
  b->bus.power_on_all();
  b->bus.run_for(sec(3));
  auto out = b->bus.take();
  ASSERT_EQ(out.size(), 1u) << to_string(out);
  EXPECT_EQ(out[0].time, 0);
  EXPECT_EQ(out[0].frame, F(0x701, {0x00}));
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
}

// 2. P as REAL32 in the current unit, within one quantum (+ noise: none here).
TEST_F(CmpAcceptance, Check02ReadPressureFloat) {
  start(quiet("3.3 bar"));
  const CanFrame r = b->upload(1, 0x6130, 1);
  EXPECT_EQ(r.id, 0x581u);
  EXPECT_EQ(r.data[0], 0x43);
  EXPECT_NEAR(CmpBus::f32(r), 3.3, kQuantumBar);
}

// 3. T as INTEGER16 = round(T x 10^dd).
TEST_F(CmpAcceptance, Check03ReadTemperatureInt16) {
  start(quiet("5 bar", "31.7 degC"));
  const CanFrame r = b->upload(1, 0x7130, 2);
  EXPECT_EQ(r.data[0], 0x4B);
  EXPECT_EQ(od(0x6132, 2), 1u);
  EXPECT_NEAR(le16(r, 4), 317, 1);  // 13-bit temperature quantum 0.02 K
}

// 4. Read-only write: exact abort frame.
TEST_F(CmpAcceptance, Check04ReadOnlyWrite) {
  start();
  auto out = b->sdo(1, {0x22, 0x00, 0x10, 0x00, 0x78, 0x56, 0x34, 0x12});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06}));
}

// 5. Unit change at node 10: readings x100, dependent objects converted.
TEST_F(CmpAcceptance, Check05UnitChangeToKpa) {
  b = std::make_unique<CmpBus>(cmp_profile(quiet("4.2 bar")));
  SimNode& n10 = b->add(10);
  b->boot();
  const float bar = CmpBus::f32(b->upload(10, 0x6130, 1));
  auto out = b->sdo(10, {0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0x22, 0x03});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x58A, {0x60, 0x31, 0x61, 0x01, 0, 0, 0, 0}));
  EXPECT_NEAR(CmpBus::f32(b->upload(10, 0x6130, 1)), 100.0 * bar, 100.0 * kQuantumBar);
  EXPECT_NEAR(le32(b->upload(10, 0x9130, 1), 4), 420000, 200);  // 420 kPa at 3 digits
  float upper = 0;
  auto v = n10.node().values().bytes(*n10.node().od().find(0x6135, 1));
  std::memcpy(&upper, v.data(), 4);
  EXPECT_FLOAT_EQ(upper, 1000.0f);  // upper threshold 10 bar -> 1000 kPa
}

// 6. T decimals at node 11.
TEST_F(CmpAcceptance, Check06TemperatureDecimals) {
  b = std::make_unique<CmpBus>(cmp_profile(quiet("5 bar", "21.37 degC")));
  b->add(11);
  b->boot();
  auto out = b->sdo(11, {0x22, 0x32, 0x61, 0x02, 0x02, 0x00, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x58B, {0x60, 0x32, 0x61, 0x02, 0, 0, 0, 0}));
  EXPECT_NEAR(le16(b->upload(11, 0x7130, 2), 4), 2137, 2);
}

// 7. P filter 1000 ms: a step becomes a linear ramp reaching the new value
// 1000 ms after the step; 65535 ms is accepted.
TEST_F(CmpAcceptance, Check07PressureFilterRamp) {
  start(quiet(steps({{0, 2}, {2, 6}})));
  auto r = b->sdo(1, {0x22, 0xA1, 0x61, 0x01, 0xE8, 0x03, 0x00, 0x00});
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].frame, F(0x581, {0x60, 0xA1, 0x61, 0x01, 0, 0, 0, 0}));
  b->bus.run_until(sec(2) + ms(500));
  EXPECT_NEAR(CmpBus::f32(b->upload(1, 0x6130, 1)), 4.0, 0.02);  // half way
  b->bus.run_until(sec(2) + ms(990));
  EXPECT_LT(CmpBus::f32(b->upload(1, 0x6130, 1)), 6.0 - 2 * kQuantumBar);
  b->bus.run_until(sec(3) + ms(5));
  EXPECT_NEAR(CmpBus::f32(b->upload(1, 0x6130, 1)), 6.0, kQuantumBar);
  EXPECT_EQ(b->download(1, 0x61A1, 1, 0xFFFF).data[0], 0x60);
}

// 8. Mapping mode 5: 0x1A00 mirrors it, is read-only, EventMask reset to 0x10.
TEST_F(CmpAcceptance, Check08MappingMode) {
  start();
  ok_write(0x2201, 1, 0x00);
  auto out = b->sdo(1, {0x22, 0x00, 0x21, 0x01, 0x05, 0x00, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x00, 0x21, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(CmpBus::u32(b->upload(1, 0x1A00, 0)) & 0xFF, 1u);
  EXPECT_EQ(CmpBus::u32(b->upload(1, 0x1A00, 1)), 0x91300120u);
  EXPECT_EQ(CmpBus::u32(b->download(1, 0x1A00, 1, 0x61300120)), 0x06010002u);
  EXPECT_EQ(CmpBus::u32(b->upload(1, 0x2201, 1)) & 0xFF, 0x10u);
  b->nmt(0x01, 0x01);
  b->bus.run_for(ms(150));
  auto pdo = only(b->bus.take(), 0x181);
  ASSERT_FALSE(pdo.empty());
  EXPECT_EQ(pdo[0].frame.dlc, 4);
  EXPECT_NEAR(le32(pdo[0].frame), 5000, 2);  // P x 10^3
}

// 9. Cyclic PDO every 100 ms in OPERATIONAL only.
TEST_F(CmpAcceptance, Check09CyclicPdo) {
  start();
  ok_write(0x1800, 2, 0xFF);
  ok_write(0x1800, 5, 100);
  b->bus.run_for(sec(1));
  EXPECT_TRUE(only(b->bus.take(), 0x181).empty());  // PRE-OPERATIONAL
  b->nmt(0x01, 0x00);
  const TimeUs t0 = b->bus.now();
  b->bus.run_for(ms(1050));
  auto pdo = only(b->bus.take(), 0x181);
  ASSERT_EQ(pdo.size(), 10u);
  for (std::size_t i = 0; i < pdo.size(); ++i) {
    EXPECT_NEAR(double(pdo[i].time - t0), double(ms(100) * TimeUs(i + 1)), double(ms(10)));
    EXPECT_EQ(pdo[i].frame.dlc, 4);
  }
  b->nmt(0x02, 0x00);
  b->bus.run_for(sec(1));
  EXPECT_TRUE(only(b->bus.take(), 0x181).empty());  // STOPPED
}

// 10. RTR on 0x181 -> one data frame with the current P.
TEST_F(CmpAcceptance, Check10Rtr) {
  start(quiet("7.5 bar"));
  ok_write(0x1800, 5, 0);
  b->nmt(0x01, 0x01);
  b->bus.run_for(ms(5));
  b->bus.take();
  b->bus.inject(CanFrame::remote(0x181, 4));
  b->bus.run_for(ms(1));
  auto pdo = only(b->bus.take(), 0x181);
  ASSERT_EQ(pdo.size(), 1u);
  EXPECT_EQ(pdo[0].frame.dlc, 4);
  EXPECT_NEAR(le32(pdo[0].frame), 7500, 2);
}

// 11. PDO4 on 0x485.
TEST_F(CmpAcceptance, Check11Pdo4On485) {
  start();
  auto out = b->sdo(1, {0x22, 0x03, 0x18, 0x01, 0x85, 0x04, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x03, 0x18, 0x01, 0, 0, 0, 0}));
  ok_write(0x2100, 4, 8);  // P_Float
  ok_write(0x1803, 2, 0xFF);
  b->nmt(0x01, 0x01);
  b->bus.run_for(ms(350));
  auto pdo = only(b->bus.take(), 0x485);
  ASSERT_EQ(pdo.size(), 3u);
  float p;
  std::memcpy(&p, pdo[0].frame.data, 4);
  EXPECT_NEAR(p, 5.0, kQuantumBar);
}

// 12. Type 254 delta: a PDO only when |P - P at the last PDO| > delta.
TEST_F(CmpAcceptance, Check12Type254Delta) {
  start(quiet("[{ramp: {from: 2 bar, to: 8 bar, start: 1 s, duration: 3 s}}]"));
  ok_write(0x1800, 2, 254);
  std::uint8_t delta[4];
  encode_f(DataType::kReal32, 0.25, delta);
  ASSERT_EQ(CmpBus::u32(b->download(1, 0x6133, 1, get_u32(delta))), 0u);
  EXPECT_EQ(od(0x2201, 1), 0x10u);
  b->nmt(0x01, 0x01);
  b->bus.run_until(sec(1));
  EXPECT_TRUE(only(b->bus.take(), 0x181).empty());  // constant pressure: nothing
  b->bus.run_until(sec(4));
  auto pdo = only(b->bus.take(), 0x181);
  ASSERT_GE(pdo.size(), 20u);  // 6 bar / 0.25 bar
  ASSERT_LE(pdo.size(), 24u);
  std::int32_t last = 2000;
  for (const Sent& f : pdo) {
    const std::int32_t p = le32(f.frame);
    EXPECT_GE(p - last, 250);  // > 0.25 bar before rounding to 3 digits
    EXPECT_LE(p - last, 254);  // 2 bar/s, checked every 1 ms
    last = p;
  }
  b->bus.run_until(sec(6));
  EXPECT_TRUE(only(b->bus.take(), 0x181).empty());  // constant again
}

// 13. Type 254 limits with hysteresis and a 200 ms event timer.
TEST_F(CmpAcceptance, Check13Type254LimitsHysteresisTimer) {
  start(quiet(steps({{0, 5}, {1, 8}, {2, 6.4}, {3, 5}, {4, 2}, {5, 3.6}, {6, 5}})));
  ok_write(0x2100, 1, 7);  // P_Int16
  ok_write(0x2201, 1, 0x03);
  ok_write(0x1800, 2, 254);
  ok_write(0x1800, 5, 200);
  for (auto [index, value] : {std::pair{0x6134, 3.0}, {0x6135, 7.0}, {0x6136, 0.5}}) {
    std::uint8_t v[4];
    encode_f(DataType::kReal32, value, v);
    ok_write(std::uint16_t(index), 1, get_u32(v));
  }
  b->nmt(0x01, 0x01);
  b->bus.run_until(sec(7));
  auto pdo = only(b->bus.take(), 0x181);
  std::vector<TimeUs> expected = {
      sec(1), sec(1) + ms(200), sec(1) + ms(400), sec(1) + ms(600), sec(1) + ms(800),  // above U
      sec(2),                                                                          // U - H down
      sec(4), sec(4) + ms(200), sec(4) + ms(400), sec(4) + ms(600), sec(4) + ms(800),  // below L
      sec(5)};                                                                         // L + H up
  ASSERT_EQ(pdo.size(), expected.size()) << to_string(pdo);
  for (std::size_t i = 0; i < pdo.size(); ++i)
    EXPECT_NEAR(double(pdo[i].time), double(expected[i]), double(ms(2))) << i;
  EXPECT_EQ(le16(pdo[0].frame), 8000);
  EXPECT_EQ(le16(pdo[5].frame), 6400);
}

// 14. Special messages (mode 30: 4 bytes; mode 27: DLC 0).
TEST_F(CmpAcceptance, Check14SpecialMessages) {
  start(quiet(steps({{0, 5}, {1, 8}, {2, 6}, {3, 8}})));
  ok_write(0x2100, 1, 30);
  EXPECT_EQ(od(0x2201, 1), 0x03u);
  ok_write(0x1800, 2, 254);
  ok_write(0x1800, 5, 0);  // single frames: no timer repeats above the threshold
  std::uint8_t v[4];
  encode_f(DataType::kReal32, 7.0, v);
  ok_write(0x6135, 1, get_u32(v));
  b->download_long(1, 0x2212, 0, {0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88});  // UpperLimitUp
  b->download_long(1, 0x2213, 0, {0xA1, 0xA2, 0xA3, 0xA4, 0xA5, 0xA6, 0xA7, 0xA8});  // UpperLimitDown
  b->nmt(0x01, 0x01);
  b->bus.run_until(sec(2) + ms(500));
  auto pdo = only(b->bus.take(), 0x181);
  ASSERT_EQ(pdo.size(), 2u) << to_string(pdo);
  EXPECT_EQ(pdo[0].frame, F(0x181, {0x11, 0x22, 0x33, 0x44}));
  EXPECT_EQ(pdo[1].frame, F(0x181, {0xA1, 0xA2, 0xA3, 0xA4}));
  ok_write(0x2100, 1, 27);
  b->bus.run_until(sec(3) + ms(50));
  pdo = only(b->bus.take(), 0x181);
  ASSERT_EQ(pdo.size(), 1u);
  EXPECT_EQ(pdo[0].frame.dlc, 0);
}

// 15a. Store: a saved unit survives a reset.
TEST_F(CmpAcceptance, Check15aSaveKeepsUnitOverReset) {
  start();
  ok_write(0x6131, 1, 0x03220000);
  auto out = b->sdo(1, {0x22, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0}));
  b->nmt(0x81, 0x01);
  b->bus.run_for(ms(1));
  EXPECT_EQ(only(b->bus.take(), 0x701).size(), 1u);
  EXPECT_EQ(od(0x6131, 1), 0x03220000u);
  EXPECT_NEAR(CmpBus::f32(b->upload(1, 0x6130, 1)), 500.0, 100 * kQuantumBar);
}

// 15b. Restore ("load") needs a following "save" (footnote 1).
TEST_F(CmpAcceptance, Check15bRestoreNeedsSave) {
  start();
  ok_write(0x6131, 1, 0x03220000);
  ok_write(0x1010, 1, 0x65766173);
  auto out = b->sdo(1, {0x22, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0}));
  b->nmt(0x81, 0x01);
  b->bus.run_for(ms(1));
  EXPECT_EQ(od(0x6131, 1), 0x03220000u);  // previous settings still active
  ok_write(0x1011, 1, 0x64616F6C);
  ok_write(0x1010, 1, 0x65766173);
  b->nmt(0x81, 0x01);
  b->bus.run_for(ms(1));
  EXPECT_EQ(od(0x6131, 1), 0x004E0000u);  // factory settings
}

// 15c. Life guarding: EMCY 0x8130 and PRE-OPERATIONAL; recovery EMCY when
// guarding resumes; no restart without Auto-Start.
TEST_F(CmpAcceptance, Check15cGuardingFault) {
  start();
  ok_write(0x100C, 0, 100);
  ok_write(0x100D, 0, 3);
  b->nmt(0x01, 0x01);
  b->bus.inject(CanFrame::remote(0x701, 1));
  const TimeUs t0 = b->bus.now();
  b->bus.run_for(ms(350));
  auto emcy = only(b->bus.take(), 0x081);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(emcy[0].frame, F(0x081, {0x30, 0x81, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_NEAR(double(emcy[0].time - t0), double(ms(300)), double(ms(5)));
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  b->bus.inject(CanFrame::remote(0x701, 1));
  b->bus.run_for(ms(100));
  auto out = b->bus.take();
  emcy = only(out, 0x081);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(emcy[0].frame, F(0x081, {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_EQ(only(out, 0x701)[0].frame, F(0x701, {0xFF}));  // toggle 1, PRE-OPERATIONAL
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
}

// 15d. Auto-Start (and 0x1F80 = 0x08) saved -> OPERATIONAL without NMT; 0x1F80
// bit 1 -> "01 00" on 0x000 250 ms after entering OPERATIONAL.
TEST_F(CmpAcceptance, Check15dAutoStartAndStartIndication) {
  start();
  ok_write(0x2200, 0, 1);
  ok_write(0x1F80, 0, 0x02);
  ok_write(0x1010, 2, 0x65766173);
  b->bus.take();
  const TimeUs t0 = b->bus.now();
  b->nmt(0x81, 0x01);
  b->bus.run_for(ms(400));
  auto all = b->bus.take();
  auto boot = only(all, 0x701), start_all = only(all, 0x000);
  ASSERT_EQ(boot.size(), 1u);
  EXPECT_EQ(boot[0].frame, F(0x701, {0x00}));
  ASSERT_EQ(start_all.size(), 1u);
  EXPECT_EQ(start_all[0].frame, F(0x000, {0x01, 0x00}));
  EXPECT_NEAR(double(start_all[0].time - t0), double(ms(250)), double(ms(10)));
  EXPECT_FALSE(only(all, 0x181).empty());  // OPERATIONAL without an NMT command
  EXPECT_EQ(node().state(), NmtState::kOperational);

  ok_write(0x2200, 0, 0);
  ok_write(0x1F80, 0, 0x08);
  ok_write(0x1010, 2, 0x65766173);
  b->nmt(0x81, 0x01);
  b->bus.run_for(ms(400));
  EXPECT_EQ(node().state(), NmtState::kOperational);
  EXPECT_TRUE(only(b->bus.take(), 0x000).empty());
}

// 15e. LSS switch selective with revision 0 (any revision); bit timing index 9.
TEST_F(CmpAcceptance, Check15eLssRevisionWildcardAndAutoBitRate) {
  start();
  b->bus.take();
  auto lss = [&](std::uint8_t cs, std::uint32_t v) {
    b->bus.inject(
        F(0x7E5, {cs, std::uint8_t(v), std::uint8_t(v >> 8), std::uint8_t(v >> 16), std::uint8_t(v >> 24), 0, 0, 0}));
    b->bus.run_for(ms(1));
  };
  lss(0x40, std::uint32_t(od(0x1018, 1)));
  lss(0x41, std::uint32_t(od(0x1018, 2)));
  lss(0x42, 0x00000000);
  lss(0x43, std::uint32_t(od(0x1018, 4)));
  auto out = b->bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x7E4, {0x44, 0, 0, 0, 0, 0, 0, 0}));
  b->bus.inject(F(0x7E5, {0x13, 0x00, 0x09, 0, 0, 0, 0, 0}));
  b->bus.run_for(ms(1));
  out = b->bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x7E4, {0x13, 0x00, 0, 0, 0, 0, 0, 0}));
  b->bus.inject(F(0x7E5, {0x13, 0x01, 0x07, 0, 0, 0, 0, 0}));  // selector 1 (bit-timing footnote)
  b->bus.run_for(ms(1));
  EXPECT_EQ(b->bus.take().at(0).frame, F(0x7E4, {0x13, 0x00, 0, 0, 0, 0, 0, 0}));
}

// 16. Mode 37: P_Int16 + P_Status + ms counter.
TEST_F(CmpAcceptance, Check16MsCounterMode) {
  start();
  auto out = b->sdo(1, {0x22, 0x00, 0x21, 0x01, 0x25, 0x00, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x60, 0x00, 0x21, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(od(0x2201, 1), 0x13u);
  EXPECT_EQ(od(0x1A00, 0), 3u);
  b->nmt(0x01, 0x01);
  b->bus.run_for(ms(550));
  auto pdo = only(b->bus.take(), 0x181);
  ASSERT_EQ(pdo.size(), 5u);
  for (std::size_t i = 0; i < pdo.size(); ++i) {
    EXPECT_EQ(pdo[i].frame.dlc, 4);
    if (i) {
      EXPECT_EQ(std::uint8_t(pdo[i].frame.data[3] - pdo[i - 1].frame.data[3]), 100);
    }
  }
}

// 17. Modes of unknown composition are refused until the table defines them.
TEST_F(CmpAcceptance, Check17UnknownModes) {
  start();
  auto out = b->sdo(1, {0x22, 0x00, 0x21, 0x01, 0x15, 0x00, 0x00, 0x00});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x581, {0x80, 0x00, 0x21, 0x01, 0x30, 0x00, 0x09, 0x06}));
  EXPECT_EQ(od(0x2100, 1), 5u);
  EXPECT_EQ(CmpBus::u32(b->download(1, 0x2100, 1, 25)), 0x06090030u);

  start([](YAML::Node& root) {
    quiet()(root);
    root["vendor"]["mapping_modes"][25] =
        YAML::Load("{entries: [0x91300120, 0x61500108, 0x71300210, 0x61500208], event_mask: 0x30}");
  });
  ok_write(0x2100, 1, 25);
  EXPECT_EQ(od(0x1A00, 0), 4u);
  b->nmt(0x01, 0x01);
  b->bus.run_for(ms(150));
  auto pdo = only(b->bus.take(), 0x181);
  ASSERT_FALSE(pdo.empty());
  EXPECT_EQ(pdo[0].frame.dlc, 8);
}

}  // namespace
}  // namespace cansim::test
