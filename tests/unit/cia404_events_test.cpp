// CiA 404 delta / limit events raising TPDO1 (type 255) on a SimBus, frame
// by frame with exact times; the filter through 0x61A0 / 0x61A1.
#include "cia404_support.hpp"

namespace cansim::test {
namespace {

constexpr std::uint32_t kTpdo1 = 0x190;  // node 0x10

class Events : public ChainFixture {
 public:
  void SetUp() override {
    ChainFixture::SetUp();
    source->pressure = [this](TimeUs t) { return level(t); };
    ASSERT_EQ(wu16(0x1800, 5, 0), SdoAbort::kNone);  // no event timer: only CiA 404 events
    bus.inject(F(0x000, {0x01, 0x10}));              // NMT start
    bus.run_for(ms(1));
    bus.take();
  }
  // Piecewise-constant pressure in bar: steps at the given times.
  std::vector<std::pair<TimeUs, double>> steps{{0, 5.0}};
  double level(TimeUs t) const {
    double v = 0;
    for (auto& [at, bar] : steps)
      if (t >= at) v = bar;
    return v * 1e5;
  }
  // The event checks run every 10 ms on the device's own grid, from its
  // power-on at t = 0: the first check at or after t. Writes and NMT
  // commands between two checks do not move the grid.
  static TimeUs check_at(TimeUs t) { return (t + ms(10) - 1) / ms(10) * ms(10); }
  static CanFrame pdo(float bar, std::uint8_t status) {
    std::uint8_t b[4];
    encode_f(DataType::kReal32, bar, b);
    return F(kTpdo1, {b[0], b[1], b[2], b[3], status});
  }
};

TEST_F(Events, NoEventsWhileTheValueIsSteady) {
  bus.run_for(ms(200));
  EXPECT_TRUE(bus.take().empty());
}

TEST_F(Events, DeltaRaisesTpdoAtTheCheckAfterTheChange) {
  ASSERT_EQ(wf(0x6133, 1, 0.5f), SdoAbort::kNone);
  const TimeUs t0 = now();
  ASSERT_NE(t0 % ms(10), 0);  // the write woke the chain between two checks
  steps = {{0, 5.0}, {t0 + ms(20), 5.4}, {t0 + ms(40), 5.6}, {t0 + ms(60), 6.0}, {t0 + ms(80), 6.2}};
  bus.run_for(ms(100));
  auto sent = bus.take();
  ASSERT_EQ(sent.size(), 2u) << to_string(sent);
  EXPECT_EQ(sent[0].time, check_at(t0 + ms(40)));  // |5.6 - 5.0| > 0.5
  EXPECT_EQ(sent[0].frame, pdo(5.6f, 0));
  EXPECT_EQ(sent[1].time, check_at(t0 + ms(80)));  // |6.2 - 5.6| > 0.5 (6.0 is not)
  EXPECT_EQ(sent[1].frame, pdo(6.2f, 0));
}

// The chain follows the TPDO configuration as the master changes it: told
// by the PDO engine, not by polling the OD.
TEST_F(Events, EventChannelsFollowTheTpdoTypeAtOnce) {
  ASSERT_EQ(wf(0x6133, 1, 0.5f), SdoAbort::kNone);
  ASSERT_EQ(wu8(0x1800, 2, 1), SdoAbort::kNone);  // synchronous: no delta events
  TimeUs t0 = now();
  steps = {{0, 5.0}, {t0 + ms(5), 6.0}};
  bus.run_for(ms(20));
  EXPECT_TRUE(bus.take().empty());
  ASSERT_EQ(wu8(0x1800, 2, 255), SdoAbort::kNone);  // event-driven again
  t0 = now();
  steps = {{0, 6.0}, {t0 + ms(1), 7.0}};
  bus.run_for(ms(15));
  auto sent = bus.take();
  ASSERT_EQ(sent.size(), 1u) << to_string(sent);
  EXPECT_EQ(sent[0].time, check_at(t0 + ms(1)));  // the first event check after the step
  EXPECT_EQ(sent[0].frame, pdo(7.0f, 0));
}

TEST_F(Events, UpperLimitFiresOncePerCrossingWithHysteresis) {
  ASSERT_EQ(wf(0x6135, 1, 7.0f), SdoAbort::kNone);
  ASSERT_EQ(wf(0x6136, 1, 0.5f), SdoAbort::kNone);
  const TimeUs t0 = now();
  steps = {{0, 5.0},           {t0 + ms(10), 7.5}, {t0 + ms(20), 6.8},
           {t0 + ms(30), 7.6}, {t0 + ms(40), 6.0}, {t0 + ms(50), 7.2}};
  bus.run_for(ms(60));
  auto sent = bus.take();
  ASSERT_EQ(sent.size(), 2u) << to_string(sent);
  EXPECT_EQ(sent[0].time, check_at(t0 + ms(10)));
  EXPECT_EQ(sent[0].frame, pdo(7.5f, 0));
  EXPECT_EQ(sent[1].time, check_at(t0 + ms(50)));  // re-armed only below 7.0 - 0.5
  EXPECT_EQ(sent[1].frame, pdo(7.2f, 0));
}

TEST_F(Events, LowerLimitAndSpanStatusInThePdo) {
  ASSERT_EQ(wf(0x6134, 1, 1.0f), SdoAbort::kNone);
  const TimeUs t0 = now();
  steps = {{0, 5.0}, {t0 + ms(7), -0.5}};
  bus.run_for(ms(20));
  auto sent = bus.take();
  ASSERT_EQ(sent.size(), 1u) << to_string(sent);
  EXPECT_EQ(sent[0].time, check_at(t0 + ms(7)));  // the first event check after the step
  EXPECT_EQ(sent[0].frame, pdo(-0.5f, 0x04));     // negative overload below span start 0
}

TEST_F(Events, NoEventsInPreOperational) {
  ASSERT_EQ(wf(0x6133, 1, 0.5f), SdoAbort::kNone);
  bus.inject(F(0x000, {0x80, 0x10}));  // pre-operational
  bus.run_for(ms(1));
  bus.take();
  const TimeUs t0 = now();
  steps = {{0, 5.0}, {t0 + ms(10), 7.0}};
  bus.run_for(ms(50));
  EXPECT_TRUE(bus.take().empty());
}

TEST(ChainFilter, MovingAverageSettlesAfterNSamples) {
  config::Profile p = prepared_repo_yaml("generic-404", [](YAML::Node& root) {
    root["physics"] = YAML::Load("{pressure: [{ramp: {from: 0 bar, to: 8 bar, start: 100 ms, duration: 0 s}}]}");
    root["sensor"] = YAML::Load("{pressure: {range: [0 bar, 10 bar], sample_rate: 1 kHz, noise: 0 bar}}");
  });
  SimBus bus;
  auto app = personalities::make_application(p, {});
  SimNode& n = bus.add(p, 0x10, app.get());
  bus.power_on_all();
  auto pv = [&] {
    std::span<const std::uint8_t> out;
    EXPECT_EQ(n->read(0x6130, 1, bus.now(), out), SdoAbort::kNone);
    return decode_f(DataType::kReal32, out.data());
  };
  std::uint8_t one[1] = {1};
  std::uint8_t four[2] = {4, 0};
  ASSERT_EQ(n->write(0x61A0, 1, one, bus.now()), SdoAbort::kNone);
  ASSERT_EQ(n->write(0x61A1, 1, four, bus.now()), SdoAbort::kNone);
  bus.run_until(ms(99));
  EXPECT_NEAR(pv(), 0.0, 1e-4);
  const double expect[] = {2.0, 4.0, 6.0, 8.0, 8.0};  // the step enters one sample at a time
  for (int k = 0; k < 5; ++k) {
    bus.run_until(ms(100 + k));
    EXPECT_NEAR(pv(), expect[k], 1e-3) << "sample " << k;
  }
  // Repeating average: the output changes only at block ends.
  std::uint8_t two[1] = {2};
  ASSERT_EQ(n->write(0x61A0, 1, two, bus.now()), SdoAbort::kNone);
  bus.run_until(ms(120));
  EXPECT_NEAR(pv(), 8.0, 1e-3);
}

TEST(ChainPhysics, SameSeedSameValuesOtherKeyOtherValues) {
  config::Profile p = load_repo_profile("generic-404");
  auto series = [&](const std::string& key) {
    SimBus bus;
    auto app = personalities::make_application(p, {42, 0, key, {}});
    SimNode& n = bus.add(p, 0x10, app.get());
    bus.power_on_all();
    std::vector<float> v;
    for (int k = 1; k <= 5; ++k) {
      bus.run_until(ms(100 * k));
      std::span<const std::uint8_t> out;
      n->read(0x6130, 1, bus.now(), out);
      v.push_back(decode_f(DataType::kReal32, out.data()));
    }
    return v;
  };
  auto a = series("vcan0/a"), b = series("vcan0/a"), c = series("vcan0/b");
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  for (float x : a) EXPECT_NEAR(x, 5.0, 1.0);  // generic: around 5 bar
}

}  // namespace
}  // namespace cansim::test
