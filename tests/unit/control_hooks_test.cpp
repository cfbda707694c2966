// The physics and personality hooks of the runtime control API
// (docs/control-api.md), frame by frame on a fake clock: a generic-404 node
// with its real physics, its process model replaced (Step, Ramp, SetModel,
// RestoreModel), overridden reports, fault edges heard when due, the armed
// fault list, a power cycle cancelled, and recording started and stopped.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/physics_config.hpp"
#include "personalities/cia404.hpp"
#include "personalities/registry.hpp"
#include "support/device.hpp"
#include "cia404_support.hpp"

namespace cansim::test {
namespace {

using physics::Channel;
using physics::FaultKind;
using ::testing::HasSubstr;

constexpr std::uint8_t kId = 0x10;
constexpr TimeUs sec(std::int64_t v) { return v * 1000000; }

// The process model's pressure in bar (the profile's unit).
constexpr double bar(double pa) { return pa / 1e5; }

// One generic-404 node (profiles/generic-404.yaml, its real physics),
// operational, with the master's SDO reads as frames.
class ControlHooks : public ::testing::Test {
 protected:
  void start(const std::function<void(YAML::Node&)>& edit = {}) {
    profile = prepared_repo_yaml("generic-404", edit);
    personalities::NodeContext ctx;
    ctx.fleet_seed = 7;
    ctx.key = "vcan0/generic";
    app = personalities::make_application(profile, ctx);
    chain = personalities::measurement_control(app.get());
    ASSERT_NE(chain, nullptr);
    sim = &bus.add(profile, kId, app.get());
    bus.power_on_all();
    bus.run_for(ms(1));
    bus.inject(F(0x000, {0x01, kId}));  // NMT start: PDOs run
    bus.run_for(ms(1));
    bus.take();
  }

  Node& node() { return sim->node(); }
  TimeUs now() const { return bus.now(); }

  // Expedited SDO upload by the master (answered at once, no bus time).
  CanFrame upload(std::uint16_t index, std::uint8_t sub) {
    bus.take();
    bus.inject(F8(0x600 + kId, {0x40, std::uint8_t(index), std::uint8_t(index >> 8), sub}));
    const CanFrame a = answer(bus.take(), 0x580 + kId);
    EXPECT_EQ(a.data[0] & 0xF0, 0x40) << std::hex << "no upload answer for " << index << ":" << int(sub);
    return a;
  }
  float pv(std::uint8_t sub) { return decode_f(DataType::kReal32, upload(0x6130, sub).data + 4); }
  std::uint32_t u32(std::uint16_t index, std::uint8_t sub) { return get_u32(upload(index, sub).data + 4); }
  void write_u32(std::uint16_t index, std::uint8_t sub, std::uint32_t v) {
    std::uint8_t b[4];
    put_u32(b, v);
    ASSERT_EQ(node().write(index, sub, b, now()), SdoAbort::kNone);
  }
  void write_f(std::uint16_t index, std::uint8_t sub, float v) {
    std::uint8_t b[4];
    encode_f(DataType::kReal32, v, b);
    ASSERT_EQ(node().write(index, sub, b, now()), SdoAbort::kNone);
  }
  physics::FaultHandle arm(const std::string& yaml) {
    return chain->arm_fault(node(), config::parse_fault({"test", "fault"}, YAML::Load(yaml)), now());
  }
  double truth(Channel ch = Channel::Pressure) { return chain->true_value_si(ch, now()); }

  SimBus bus;
  config::Profile profile;
  std::unique_ptr<Application> app;
  personalities::MeasurementControl* chain = nullptr;
  SimNode* sim = nullptr;
};

// ---------------------------------------------------------------- process model

TEST_F(ControlHooks, StepSetsTheTruthAndThePvAndTpdoFollow) {
  start();
  bus.run_for(ms(500));
  const TimeUs t0 = now();
  ASSERT_TRUE(chain->step(node(), Channel::Pressure, 7.0e5, t0));
  EXPECT_EQ(truth(), 7.0e5);
  bus.run_for(ms(20));
  EXPECT_NEAR(pv(1), 7.0, 0.01);  // noise 1 mbar, 16-bit ADC
  bus.take();
  bus.run_for(ms(250));
  const std::vector<Sent> tpdo1 = only(bus.take(), 0x180 + kId);
  ASSERT_FALSE(tpdo1.empty());
  EXPECT_NEAR(decode_f(DataType::kReal32, tpdo1.back().frame.data), 7.0, 0.01);
  EXPECT_NEAR(pv(2), 22.5, 2.6);  // the temperature keeps its model

  const auto v = chain->view(node(), Channel::Pressure, now());
  EXPECT_EQ(v.unit, "bar");
  EXPECT_EQ(v.true_value, 7.0);
  EXPECT_NEAR(v.reported, 7.0, 0.01);
  EXPECT_EQ(v.status, 0);
}

TEST_F(ControlHooks, HoldKeepsThePresentTrueValue) {
  start();
  bus.run_for(ms(300));
  const double held = truth();
  ASSERT_TRUE(chain->hold(node(), Channel::Pressure, now()));
  for (int k = 0; k < 5; ++k) {
    bus.run_for(sec(7));
    EXPECT_EQ(truth(), held);  // the profile's OU would wander
  }
}

TEST_F(ControlHooks, RampRunsFromThePresentValueOverTheGivenTime) {
  start();
  bus.run_for(ms(300));
  const TimeUs t0 = now();
  const double from = truth();
  ASSERT_TRUE(chain->ramp(node(), Channel::Pressure, 9.0e5, 2.0, t0));
  EXPECT_EQ(truth(), from);
  bus.run_until(t0 + sec(1));
  EXPECT_NEAR(truth(), (from + 9.0e5) / 2, 1e-3);
  EXPECT_NEAR(pv(1), bar((from + 9.0e5) / 2), 0.01);
  bus.run_until(t0 + sec(2));
  EXPECT_NEAR(truth(), 9.0e5, 1e-3);
  bus.run_until(t0 + sec(3));
  EXPECT_EQ(truth(), 9.0e5);
  EXPECT_NEAR(pv(1), 9.0, 0.01);
}

TEST_F(ControlHooks, SetModelFromYamlStartsNow) {
  start();
  bus.run_for(ms(1234));
  const TimeUs t0 = now();
  const auto terms = config::parse_channel_model(
      {"control", "pressure"}, YAML::Load("[{constant: 2 bar}, {sine: {amplitude: 0.5 bar, period: 4 s}}]"),
      Channel::Pressure);
  ASSERT_TRUE(chain->set_process(node(), Channel::Pressure, terms, t0));
  EXPECT_NEAR(truth(), 2.0e5, 1e-3);  // the sine's time 0 is now
  bus.run_until(t0 + sec(1));
  EXPECT_NEAR(truth(), 2.5e5, 1e-3);
  EXPECT_NEAR(pv(1), 2.5, 0.01);
  bus.run_until(t0 + sec(3));
  EXPECT_NEAR(truth(), 1.5e5, 1e-3);
  EXPECT_NEAR(pv(1), 1.5, 0.01);
}

TEST_F(ControlHooks, SetModelErrorsNameWhereAndChangeNothing) {
  const config::Where w{"SetModel", "pressure"};
  try {
    config::parse_channel_model(w, YAML::Load("{sine: {amplitude: loud}}"), Channel::Pressure);
    FAIL() << "no error";
  } catch (const config::ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("SetModel:1:"));
    EXPECT_THAT(e.what(), HasSubstr("pressure.sine.amplitude: expected a pressure"));
  }
  EXPECT_THROW(config::parse_channel_model(w, YAML::Load("{gas_law: {}}"), Channel::Temperature), config::ConfigError);
  EXPECT_THROW(config::parse_channel_model(w, YAML::Load("[]"), Channel::Pressure), config::ConfigError);
  EXPECT_EQ(config::parse_channel_model(w, YAML::Load("3 bar"), Channel::Pressure).size(), 1u);

  start();
  ASSERT_TRUE(chain->step(node(), Channel::Pressure, 6.0e5, now()));
  EXPECT_THROW(chain->ramp(node(), Channel::Pressure, 8.0e5, -1.0, now()), std::invalid_argument);
  bus.run_for(ms(100));
  EXPECT_EQ(truth(), 6.0e5);
}

TEST_F(ControlHooks, RestoreModelReturnsToTheProfile) {
  start();
  ASSERT_TRUE(chain->step(node(), Channel::Pressure, 9.0e5, now()));
  bus.run_for(ms(50));
  EXPECT_NEAR(pv(1), 9.0, 0.01);
  ASSERT_TRUE(chain->restore_process(node(), Channel::Pressure, now()));
  ASSERT_TRUE(chain->restore_process(node(), Channel::Temperature, now()));  // never replaced: no-op
  EXPECT_NEAR(bar(truth()), 5.0, 0.5);                                       // 5 bar + OU (0.1 bar)
  bus.run_for(ms(50));
  EXPECT_NEAR(pv(1), 5.0, 0.5);
  EXPECT_NEAR(pv(2), 22.5, 2.6);
}

TEST_F(ControlHooks, GasLawPressureFollowsAReplacedTemperature) {
  start();
  const auto gas = config::parse_channel_model(
      {"control", "pressure"}, YAML::Load("{gas_law: {reference_pressure: 2 bar, reference_temperature: 300 K}}"),
      Channel::Pressure);
  ASSERT_TRUE(chain->set_process(node(), Channel::Pressure, gas, now()));
  ASSERT_TRUE(chain->step(node(), Channel::Temperature, 330.0, now()));
  EXPECT_NEAR(truth(), 2.2e5, 1e-6);
  bus.run_for(ms(100));
  EXPECT_NEAR(pv(1), 2.2, 0.01);
  EXPECT_NEAR(pv(2), 330.0 - 273.15, 0.05);
}

// A model replaced while the sensor was not read: the samples before the
// change keep the old truth, so a 200-sample moving average moves by 1/200
// one sample later (without the catch-up it would jump to the new value).
TEST(ControlSensor, ReplacingTheProcessKeepsWhatWasSampledBefore) {
  physics::SensorSpec sensor = config::default_sensor();
  sensor.pressure.noise_rms = 0.0;
  sensor.pressure.filter = {physics::FilterType::MovingAverage, 200, 0.0};
  physics::ProcessSpec process;
  process.pressure = physics::constant_terms(5.0e5);
  process.temperature = physics::constant_terms(293.15);
  personalities::SensorSource source(sensor, process, {}, 1);
  source.sample(Channel::Pressure, ms(100));
  source.set_process(Channel::Pressure, physics::constant_terms(8.0e5), ms(500));
  EXPECT_EQ(source.true_value(Channel::Pressure, ms(500)), 8.0e5);
  EXPECT_NEAR(source.sample(Channel::Pressure, ms(501)).si, 5.0e5 + 3.0e5 / 200, 50.0);
  EXPECT_NEAR(source.sample(Channel::Pressure, ms(800)).si, 8.0e5, 50.0);
  source.restore_process(Channel::Pressure, ms(800));
  EXPECT_EQ(source.true_value(Channel::Pressure, ms(900)), 5.0e5);
}

TEST(ControlProcess, SetChannelRunsOnItsOwnTimeAxisAndRestores) {
  physics::ProcessSpec spec;
  spec.pressure = physics::constant_terms(1.0e5);
  spec.temperature = physics::constant_terms(300.0);
  physics::ProcessModel model(spec, 3);
  model.set_channel(Channel::Pressure, physics::ramp_terms(1.0, 3.0, 0.0, 2.0), 3, 10.0);
  EXPECT_EQ(model.at(10.0).pressure_pa, 1.0);
  EXPECT_EQ(model.at(11.0).pressure_pa, 2.0);
  EXPECT_EQ(model.at(12.0).pressure_pa, 3.0);
  EXPECT_EQ(model.at(12.0).temperature_k, 300.0);
  EXPECT_THROW(model.set_channel(Channel::Temperature, {physics::GasLawSpec{}}, 3), std::invalid_argument);
  EXPECT_EQ(model.at(13.0).temperature_k, 300.0);  // unchanged by the refused model
  model.restore_channel(Channel::Pressure);
  EXPECT_EQ(model.at(14.0).pressure_pa, 1.0e5);
}

TEST(ControlProcess, PeekDoesNotAdvanceStochasticTerms) {
  physics::ProcessSpec spec;
  spec.pressure = {physics::OrnsteinUhlenbeckSpec{5.0e5, 10.0, 1.0e4, physics::kNaN}};
  physics::ProcessModel looked_at(spec, 9), untouched(spec, 9);
  const double at1 = looked_at.at(1.0).pressure_pa;
  EXPECT_EQ(looked_at.peek(1.5).pressure_pa, at1);  // the latest value
  EXPECT_EQ(untouched.at(1.0).pressure_pa, at1);
  EXPECT_EQ(looked_at.at(2.0).pressure_pa, untouched.at(2.0).pressure_pa);
}

// ---------------------------------------------------------------- overrides

TEST_F(ControlHooks, OverrideIsReportedExactlyAndAtOnce) {
  start();
  write_f(0x6133, 1, 0.5f);  // delta 0.5 bar: TPDO1 (type 255) sends on a change
  bus.run_for(ms(505) + 250);
  bus.take();
  const TimeUs t = now();
  chain->set_override(node(), Channel::Pressure, 3.25e5, t);
  bus.run_until(t);  // what is due now
  const std::vector<Sent> tpdo1 = only(bus.take(), 0x180 + kId);
  ASSERT_FALSE(tpdo1.empty());
  EXPECT_EQ(tpdo1.front().time, t);
  EXPECT_EQ(decode_f(DataType::kReal32, tpdo1.front().frame.data), 3.25f);
  for (int k = 0; k < 5; ++k) {
    bus.run_for(ms(7));
    EXPECT_EQ(pv(1), 3.25f);
    EXPECT_EQ(std::int16_t(get_u16(upload(0x7130, 1).data + 4)), 325);  // 2 digits
    EXPECT_EQ(u32(0x6150, 1) & 0xFF, 0u);
  }
  const auto v = chain->view(node(), Channel::Pressure, now());
  EXPECT_EQ(v.reported, 3.25);
  EXPECT_NEAR(v.true_value, 5.0, 0.5);  // the truth goes on
  auto overrides = chain->overrides();
  ASSERT_EQ(overrides.size(), 1u);
  EXPECT_EQ(overrides[0].channel, Channel::Pressure);
  EXPECT_EQ(overrides[0].value, 3.25);
  EXPECT_EQ(overrides[0].unit, "bar");

  write_u32(0x6131, 1, 0xFD4E0000);  // mbar: the override is a pressure, not a number
  EXPECT_EQ(pv(1), 3250.0f);
  overrides = chain->overrides();
  ASSERT_EQ(overrides.size(), 1u);
  EXPECT_NEAR(overrides[0].value, 3250.0, 1e-9);
  EXPECT_EQ(overrides[0].unit, "mbar");

  chain->set_override(node(), Channel::Pressure, std::nullopt, now());
  bus.run_for(ms(20));
  EXPECT_TRUE(chain->overrides().empty());
  EXPECT_NE(pv(1), 3250.0f);
  EXPECT_NEAR(pv(1), 5000.0, 500.0);
}

TEST_F(ControlHooks, OverrideReportsValidDuringAnOpenCircuit) {
  start();
  arm("{kind: open}");
  bus.run_for(ms(20));
  EXPECT_EQ(u32(0x6150, 1) & 0x01, 0x01u);
  chain->set_override(node(), Channel::Pressure, 4.0e5, now());
  EXPECT_EQ(u32(0x6150, 1) & 0xFF, 0u);
  EXPECT_EQ(pv(1), 4.0f);
  chain->set_override(node(), Channel::Pressure, std::nullopt, now());
  EXPECT_EQ(u32(0x6150, 1) & 0x01, 0x01u);
}

// ---------------------------------------------------------------- faults

struct Heard {
  TimeUs when;  // bus time of the call
  TimeUs edge;
  physics::FaultHandle handle;
  FaultKind kind;
  bool started;
  bool operator==(const Heard&) const = default;
};
void PrintTo(const Heard& h, std::ostream* os) {
  *os << "{" << h.when << ", " << h.edge << ", " << h.handle << ", " << physics::to_string(h.kind) << ", "
      << (h.started ? "start" : "end") << "}";
}

TEST_F(ControlHooks, FaultListenerHearsEveryEdgeWhenItIsDue) {
  start(
      [](YAML::Node& root) { root["faults"] = YAML::Load("[{kind: drift, at: 2 s, duration: 1 s, drift: 0.1 bar}]"); });
  std::vector<Heard> heard;
  chain->set_fault_listener([&](const physics::FaultEdge& e) {
    heard.push_back({bus.now(), e.time_us, e.handle, e.kind, e.started});
  });
  const TimeUs t0 = now();
  const auto drift = arm("{kind: drift, after: 1.5 s, duration: 2 s, drift: 0.2 bar}");
  const auto silent = arm("{kind: silent, after: 400 ms, duration: 1 s}");
  bus.run_for(sec(5));
  auto at = [](TimeUs t, physics::FaultHandle h, FaultKind k, bool started) { return Heard{t, t, h, k, started}; };
  EXPECT_THAT(heard, ::testing::ElementsAre(at(t0 + ms(400), silent, FaultKind::Silent, true),
                                            at(t0 + ms(1400), silent, FaultKind::Silent, false),
                                            at(t0 + ms(1500), drift, FaultKind::Drift, true),
                                            at(sec(2), 0, FaultKind::Drift, true),  // the profile's
                                            at(sec(3), 0, FaultKind::Drift, false),
                                            at(t0 + ms(3500), drift, FaultKind::Drift, false)));
  int in_silence = 0, after = 0;
  for (const Sent& s : bus.log()) {
    if (s.time >= t0 + ms(400) && s.time < t0 + ms(1400)) ++in_silence;
    if (s.time >= t0 + ms(1400)) ++after;
  }
  EXPECT_EQ(in_silence, 0);
  EXPECT_GT(after, 10);
}

TEST_F(ControlHooks, ListFaultsShowsTheArmedOnes) {
  start();
  const TimeUs t0 = now();
  const auto drift = arm("{kind: drift, channel: temperature, after: 1 s, duration: 2 s, drift: 0.1 K}");
  const auto silent = arm("{kind: silent, after: 500 ms, duration: 100 ms, period: 1 s, count: 3}");
  const auto open = arm("{kind: open}");
  auto list = chain->faults(now());
  ASSERT_EQ(list.size(), 3u);
  EXPECT_EQ(list[0].handle, drift);
  EXPECT_EQ(list[0].kind, FaultKind::Drift);
  EXPECT_EQ(list[0].channel, physics::FaultChannel::Temperature);
  EXPECT_FALSE(list[0].active);
  EXPECT_EQ(list[0].first_start, t0 + sec(1));
  EXPECT_EQ(list[0].duration_us, sec(2));
  EXPECT_EQ(list[0].period_us, 0);
  EXPECT_EQ(list[0].count, 1u);
  EXPECT_EQ(list[1].handle, silent);
  EXPECT_EQ(list[1].first_start, t0 + ms(500));
  EXPECT_EQ(list[1].duration_us, ms(100));
  EXPECT_EQ(list[1].period_us, sec(1));
  EXPECT_EQ(list[1].count, 3u);
  EXPECT_EQ(list[2].handle, open);
  EXPECT_TRUE(list[2].active);
  EXPECT_EQ(list[2].first_start, t0);
  EXPECT_EQ(list[2].duration_us, -1);

  bus.run_until(t0 + ms(1550));
  list = chain->faults(now());
  ASSERT_EQ(list.size(), 3u);
  EXPECT_TRUE(list[0].active);
  EXPECT_TRUE(list[1].active);  // the second occurrence
  ASSERT_TRUE(chain->cancel_fault(node(), open, now()));
  EXPECT_EQ(chain->faults(now()).size(), 2u);
  bus.run_until(t0 + ms(2700));
  list = chain->faults(now());
  ASSERT_EQ(list.size(), 1u);  // the silent one has had its three occurrences
  EXPECT_EQ(list[0].handle, drift);
  bus.run_until(t0 + sec(3));
  EXPECT_TRUE(chain->faults(now()).empty());
  EXPECT_FALSE(chain->cancel_fault(node(), 99, now()));
}

TEST_F(ControlHooks, CancellingAnActivePowerCycleBootsTheNodeAtOnce) {
  start();
  std::vector<Heard> heard;
  chain->set_fault_listener([&](const physics::FaultEdge& e) {
    heard.push_back({bus.now(), e.time_us, e.handle, e.kind, e.started});
  });
  const auto cycle = arm("{kind: power_cycle, after: 100 ms, duration: 10 s}");
  bus.run_for(sec(1));
  EXPECT_FALSE(node().powered());
  bus.take();
  const TimeUs t = now() + 333;
  bus.run_until(t);
  ASSERT_TRUE(chain->cancel_fault(node(), cycle, t));
  bus.run_until(t);
  EXPECT_TRUE(node().powered());
  const std::vector<Sent> boot = only(bus.take(), 0x700 + kId);
  ASSERT_EQ(boot.size(), 1u);
  EXPECT_EQ(boot[0].time, t);
  EXPECT_EQ(boot[0].frame, F(0x700 + kId, {0x00}));
  ASSERT_EQ(heard.size(), 2u);
  EXPECT_EQ(heard[1], (Heard{t, t, cycle, FaultKind::PowerCycle, false}));

  // A cycle cancelled before it began leaves the node alone.
  const auto later = arm("{kind: power_cycle, after: 1 s, duration: 1 s}");
  ASSERT_TRUE(chain->cancel_fault(node(), later, now()));
  bus.run_for(sec(3));
  EXPECT_TRUE(node().powered());
  int boot_ups = 0, heartbeats = 0;
  for (const Sent& s : only(bus.take(), 0x700 + kId)) ++(s.frame.data[0] == 0x00 ? boot_ups : heartbeats);
  EXPECT_EQ(boot_ups, 0);
  EXPECT_GE(heartbeats, 2);
}

// ---------------------------------------------------------------- recording

std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

TEST_F(ControlHooks, RecordingStartsAndStops) {
  start();
  const std::string first = ::testing::TempDir() + "control_hooks_first.csv";
  const std::string second = ::testing::TempDir() + "control_hooks_second.csv";
  std::string error;
  ASSERT_TRUE(chain->start_recording(node(), first, &error, now())) << error;
  EXPECT_EQ(chain->recording(), first);
  bus.run_for(ms(200));
  ASSERT_TRUE(chain->start_recording(node(), second, &error, now())) << error;  // replaces the first
  EXPECT_EQ(chain->recording(), second);
  const std::size_t first_rows = lines_of(first).size();
  EXPECT_GT(first_rows, 10u);  // header + a row per 10 ms event check
  EXPECT_EQ(lines_of(first)[0] + "\n", physics::CsvRecorder::header());
  bus.run_for(ms(200));
  chain->stop_recording();
  EXPECT_EQ(chain->recording(), "");
  const std::size_t second_rows = lines_of(second).size();
  EXPECT_GT(second_rows, 10u);
  bus.run_for(ms(200));
  EXPECT_EQ(lines_of(first).size(), first_rows);
  EXPECT_EQ(lines_of(second).size(), second_rows);

  EXPECT_FALSE(chain->start_recording(node(), "/nonexistent-dir/x.csv", &error, now()));
  EXPECT_THAT(error, HasSubstr("/nonexistent-dir/x.csv"));
  EXPECT_EQ(chain->recording(), "");
}

// ---------------------------------------------------------------- odds and ends

TEST(ControlHelpers, UnitsHaveTheControlApiNames) {
  using model::builtin_unit;
  using model::named_unit;
  EXPECT_EQ(named_unit("mbar")->name, "mbar");
  EXPECT_EQ(named_unit("°C")->name, "degC");
  EXPECT_EQ(named_unit("torr")->name, "mmHg");
  EXPECT_EQ(builtin_unit(0x004E0100)->name, "bar");  // SMC: a denominator in bits 15-0
  EXPECT_EQ(builtin_unit(model::make_unit(3, model::unit_code::kPascal))->name, "kPa");
  EXPECT_EQ(builtin_unit(model::make_unit(0, model::unit_code::kFahrenheit))->name, "degF");
  EXPECT_EQ(builtin_unit(model::make_unit(-6, model::unit_code::kBar))->name, "");
}

TEST(ControlHelpers, ParseFaultIsPublic) {
  const physics::FaultSpec f = config::parse_fault({"ArmFault", "params"}, YAML::Load("{kind: stuck, value: 3 bar}"));
  EXPECT_EQ(f.kind, FaultKind::StuckValue);
  EXPECT_EQ(f.stuck_value, 3.0e5);
  EXPECT_EQ(f.timing.duration_us, -1);
  EXPECT_THROW(config::parse_fault({"ArmFault", "params"}, YAML::Load("{kind: melt}")), config::ConfigError);
}

TEST(ControlHelpers, EveryPersonalityOffersMeasurementControl) {
  for (const char* name : {"generic-404", "dps", "p92c", "gems9000", "smc", "cmp"}) {
    config::Profile p = load_repo_profile(name);
    auto app = personalities::make_application(p, {});
    EXPECT_NE(personalities::measurement_control(app.get()), nullptr) << name;
  }
  EXPECT_EQ(personalities::measurement_control(nullptr), nullptr);
  Application plain;
  EXPECT_EQ(personalities::measurement_control(&plain), nullptr);
}

// A source without a process model (a test's fake): the process methods say
// no, overrides still work.
class ControlWithoutPhysics : public ChainFixture {};

TEST_F(ControlWithoutPhysics, ProcessMethodsRefuseOverridesWork) {
  EXPECT_FALSE(app->chain().has_process());
  EXPECT_TRUE(app->has_channel(Channel::Temperature));
  EXPECT_FALSE(app->step(node(), Channel::Pressure, 1.0e5, now()));
  EXPECT_TRUE(std::isnan(app->true_value_si(Channel::Pressure, now())));
  EXPECT_TRUE(app->faults(now()).empty());
  std::string error;
  EXPECT_FALSE(app->start_recording(node(), "/tmp/x.csv", &error, now()));
  app->set_override(node(), Channel::Temperature, 300.0, now());
  EXPECT_NEAR(f(0x6130, 2), 26.85f, 1e-4);
  const auto v = app->view(node(), Channel::Temperature, now());
  EXPECT_EQ(v.unit, "degC");
  EXPECT_TRUE(std::isnan(v.true_value));
}

}  // namespace
}  // namespace cansim::test
