// Registry + generic personality: profile validation errors, serial numbers
// per node, physics defaults, hooks set on the CiA 404 objects, the sensor
// faults signalled as CiA 404 devices do (EMCY, 0x1001, 0x1003, error reset).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "personalities/generic.hpp"
#include "personalities/registry.hpp"
#include "personalities/sensor_source.hpp"
#include "support/device.hpp"

namespace cansim::test {
namespace {

using ::testing::HasSubstr;

float read_f(SimNode& n, std::uint16_t i, std::uint8_t s, TimeUs now) {
  std::span<const std::uint8_t> out;
  EXPECT_EQ(n->read(i, s, now, out), SdoAbort::kNone);
  return decode_f(DataType::kReal32, out.data());
}

TEST(Generic, UnknownPersonalityNamesFileLineAndKey) {
  const std::string text =
      "name: t\npersonality: wizard\nobjects:\n  - {index: 0x1000, type: UNSIGNED32, access: ro}\n";
  EXPECT_THAT(load_error(text), HasSubstr("t.yaml:2:14: personality: unknown personality 'wizard' (expected: generic"));
}

TEST(Generic, VendorSectionIsValidated) {
  auto with_vendor = [](const char* vendor) {
    return repo_yaml_error("generic-404", [&](YAML::Node& root) { root["vendor"] = YAML::Load(vendor); });
  };
  EXPECT_THAT(with_vendor("{colour: red}"),
              HasSubstr("vendor.colour: unknown key (expected one of: cia404, serial_number_base)"));
  EXPECT_THAT(with_vendor("{cia404: {limit_trigger: sometimes}}"),
              HasSubstr("vendor.cia404.limit_trigger: expected edge or level"));
  EXPECT_THAT(with_vendor("{cia404: {channels: [{sub: 1, units: [parsec]}]}}"),
              HasSubstr("vendor.cia404.channels[0].units[0]: unknown unit"));
  EXPECT_THAT(with_vendor("{cia404: {channels: [{sub: 2, quantity: temperature, units: [bar]}]}}"),
              HasSubstr("unit of the wrong quantity"));
  EXPECT_THAT(with_vendor("{cia404: {channels: [{sub: 1, units: [atm]}]}}"),
              HasSubstr("this unit has no CiA 303-2 code built in: give 'code'"));
}

// Every chain setting is parsed by its declared kind (model/cia404_settings.hpp).
TEST(Generic, ChainSettingsParseByTheirKind) {
  const config::Profile p = prepared_repo_yaml("generic-404", [](YAML::Node& root) {
    root["vendor"] = YAML::Load(
        "{cia404: {event_check_period: 20 ms, event_tpdo_types: '0,254', event_channels: all, limit_trigger: level,"
        " filter_type_without_object: repeating_average, autozero_signature: 0x12345678, digits_on_unit_change: clamp,"
        " autozero_target: correction, unit_informational: true, span_compare: input, negative_abort: 0x06090030}}");
  });
  const model::Cia404Settings& s = p.cia404->settings;
  EXPECT_EQ(s.event_check_period_us, 20000);
  EXPECT_EQ(s.event_tpdo_types.text(), "0,254");
  EXPECT_TRUE(s.events_all_channels);
  EXPECT_TRUE(s.limit_level);
  EXPECT_EQ(s.filter_type_without_object, model::FilterTypeCode::kRepeatingAverage);
  EXPECT_EQ(s.autozero_signature, 0x12345678u);
  EXPECT_EQ(s.digits_on_unit_change, model::DigitsOnUnitChange::kClamp);
  EXPECT_TRUE(s.autozero_to_correction);
  EXPECT_TRUE(s.unit_informational);
  EXPECT_TRUE(s.span_compares_input);
  EXPECT_EQ(s.negative_abort, SdoAbort::kInvalidValue);
  EXPECT_EQ(s.bad_unit_abort, SdoAbort::kInvalidValue);  // not given: the CiA 404 default
}

TEST(Generic, ABadChainSettingNamesItsPlaceAndItsKind) {
  auto with_cia404 = [](const char* cia404) {
    return repo_yaml_error("generic-404", [&](YAML::Node& root) { root["vendor"]["cia404"] = YAML::Load(cia404); });
  };
  EXPECT_THAT(with_cia404("{event_check_period: -1 s}"),
              HasSubstr("vendor.cia404.event_check_period: expected a time >= 0"));
  EXPECT_THAT(with_cia404("{event_tpdo_types: '1-300'}"), HasSubstr("vendor.cia404.event_tpdo_types: expected ranges"));
  EXPECT_THAT(
      with_cia404("{filter_type_without_object: median}"),
      HasSubstr("vendor.cia404.filter_type_without_object: expected one of none, moving_average, repeating_average"));
  EXPECT_THAT(with_cia404("{digits_on_unit_change: round}"),
              HasSubstr("vendor.cia404.digits_on_unit_change: expected one of keep, reject, clamp, adjust"));
  EXPECT_THAT(with_cia404("{autozero_target: both}"),
              HasSubstr("vendor.cia404.autozero_target: expected offset or correction"));
  EXPECT_THAT(with_cia404("{unit_informational: maybe}"), HasSubstr("vendor.cia404.unit_informational:"));
  EXPECT_THAT(with_cia404("{bad_unit_abort: 0x100000000}"), HasSubstr("vendor.cia404.bad_unit_abort:"));
  EXPECT_THAT(
      with_cia404("{autozero_sig: 1}"),
      HasSubstr("vendor.cia404.autozero_sig: unknown key (expected one of: event_check_period, event_tpdo_types"));
  EXPECT_THAT(with_cia404("{channels: [{sub: 1, quantity: humidity}]}"),
              HasSubstr("vendor.cia404.channels[0].quantity: expected pressure or temperature"));
}

TEST(Generic, PhysicsErrorsComeFromTheProfileFile) {
  EXPECT_EQ(repo_yaml_error("generic-404", {}), "no error");
  const std::string error = repo_yaml_error(
      "generic-404", [](YAML::Node& root) { root["sensor"] = YAML::Load("{pressure: {sample_rate: fast}}"); });
  EXPECT_THAT(error, HasSubstr("generic-404.yaml:"));
  EXPECT_THAT(error, HasSubstr("sensor.pressure.sample_rate: expected a frequency"));
}

TEST(Generic, LoadingSetsHooksOnTheChainObjects) {
  // Delta / limits have no hook in the file; the chain needs them.
  config::Profile p = load_repo_profile("generic-404");
  EXPECT_EQ(p.layout->find(0x6133, 1)->hooks, kHookWrite);
  EXPECT_EQ(p.layout->find(0x6130, 2)->hooks, kHookRead);
  EXPECT_EQ(p.layout->find(0x9130, 1)->hooks, kHookRead);
  EXPECT_EQ(p.layout->find(0x6131, 1)->hooks, kHookWrite);
}

TEST(Generic, SerialNumberIsBasePlusIndex) {
  config::Profile p = load_repo_profile("generic-404");
  SimBus bus;
  auto a0 = personalities::make_application(p, {1, 0, "a", {}});
  auto a7 = personalities::make_application(p, {1, 7, "b", {}});
  SimNode& n0 = bus.add(p, 0x10, a0.get(), config::node_setup(p, 0x10, 0).serial_number);
  SimNode& n7 = bus.add(p, 0x11, a7.get(), config::node_setup(p, 0x11, 7).serial_number);
  bus.power_on_all();
  EXPECT_EQ(n0->values().u(0x1018, 4), 1u);
  EXPECT_EQ(n7->values().u(0x1018, 4), 8u);
  bus.inject(F(0x000, {0x82, 0x11}));  // reset communication keeps it
  bus.run_for(ms(10));
  EXPECT_EQ(n7->values().u(0x1018, 4), 8u);
}

TEST(Generic, MeasuresAroundFiveBarAndRoomTemperature) {
  config::Profile p = load_repo_profile("generic-404");
  SimBus bus;
  auto app = personalities::make_application(p, {7, 0, "vcan0/g", {}});
  ASSERT_TRUE(app);
  SimNode& n = bus.add(p, 0x10, app.get());
  bus.power_on_all();
  for (int k = 1; k <= 10; ++k) {
    bus.run_until(ms(1000) * k);
    const float bar = read_f(n, 0x6130, 1, bus.now());
    const float degc = read_f(n, 0x6130, 2, bus.now());
    EXPECT_GT(bar, 4.0f);
    EXPECT_LT(bar, 6.0f);
    EXPECT_GT(degc, 19.5f);
    EXPECT_LT(degc, 25.5f);
  }
}

// A generic-404 node (node-ID 0x10) with the given profile faults, its
// pressure process at `pressure_bar`.
class GenericFaults : public ::testing::Test {
 protected:
  void start(const std::string& faults, double pressure_bar = 5.0) {
    profile = prepared_repo_yaml("generic-404", [&](YAML::Node& root) {
      root["faults"] = YAML::Load(faults);
      root["physics"]["pressure"] = YAML::Load("[{constant: " + std::to_string(pressure_bar) + " bar}]");
    });
    app = personalities::make_application(profile, {7, 0, "vcan0/g", {}});
    sim = &bus.add(profile, 0x10, app.get());
    bus.power_on_all();
  }
  // The EMCYs sent in [from, to), as frames.
  std::vector<CanFrame> emcys(TimeUs from, TimeUs to) {
    std::vector<CanFrame> out;
    for (const Sent& s : bus.log())
      if (s.time >= from && s.time < to && s.frame.id == 0x90) out.push_back(s.frame);
    return out;
  }
  std::uint64_t u(std::uint16_t i, std::uint8_t sub) {
    std::span<const std::uint8_t> out;
    EXPECT_EQ(sim->node().read(i, sub, bus.now(), out), SdoAbort::kNone);
    return decode_u(sim->node().od().find(i, sub)->type, out.data());
  }

  SimBus bus;
  config::Profile profile;
  std::unique_ptr<Application> app;
  SimNode* sim = nullptr;
};

// `open` on the pressure channel: EMCY 0x5030 (sensor fault) with 0x1001 =
// generic + device profile bits, channel 1 and its 0x6150 in bytes 3-4, a
// 0x1003 entry; the error reset when the fault ends.
TEST_F(GenericFaults, AnOpenSensorRaisesTheSensorFaultEmcyAndItsErrorReset) {
  start("[{kind: open, after: 1 s, duration: 2 s}]");
  bus.run_until(ms(2900));
  EXPECT_EQ(emcys(0, ms(1000)), std::vector<CanFrame>{});
  EXPECT_EQ(emcys(ms(1000), ms(2900)), (std::vector<CanFrame>{F(0x90, {0x30, 0x50, 0x21, 0x01, 0x01, 0, 0, 0})}));
  EXPECT_EQ(u(0x1001, 0), 0x21u);
  EXPECT_EQ(u(0x1003, 0), 1u);
  EXPECT_EQ(u(0x1003, 1), 0x01015030u);
  EXPECT_EQ(u(0x6150, 1) & 0x01, 1u);
  bus.run_until(ms(3100));
  EXPECT_EQ(emcys(ms(2900), ms(3100)), (std::vector<CanFrame>{F(0x90, {0, 0, 0, 0, 0, 0, 0, 0})}));
  EXPECT_EQ(u(0x1001, 0), 0u);
  EXPECT_EQ(u(0x1003, 0), 1u);  // the history keeps it
}

// A short on the temperature channel: the same code for channel 2.
TEST_F(GenericFaults, AShortOnTheTemperatureChannelNamesChannelTwo) {
  start("[{kind: short, channel: temperature, after: 500 ms}]");
  bus.run_until(ms(1000));
  const std::vector<CanFrame> e = emcys(0, ms(1000));
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].data[0] | e[0].data[1] << 8, 0x5030);
  EXPECT_EQ(e[0].data[3], 2);
}

// A pressure beyond the span: EMCY 0xF001 (measuring range exceeded) while
// 0x6150 reports the overload, from power-on (after the boot-up).
TEST_F(GenericFaults, AnOverloadRaisesTheRangeEmcy) {
  start("[]", 14.0);
  bus.run_until(ms(100));
  const std::vector<CanFrame> e = emcys(0, ms(100));
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].data[0] | e[0].data[1] << 8, 0xF001);
  EXPECT_EQ(e[0].data[2], 0x21);
  EXPECT_EQ(e[0].data[3], 1);
  EXPECT_EQ(e[0].data[4], 0x02);  // positive overload
  const auto& boot = bus.log().front();
  EXPECT_EQ(boot.frame.id, 0x710u);  // the boot-up first
}

// Reset node forgets the EMCY state with the EMCY producer: a fault that
// lasts is signalled again after the reset.
TEST_F(GenericFaults, AFaultThatOutlastsAResetIsSignalledAgain) {
  start("[{kind: open, after: 200 ms}]");
  bus.run_until(ms(500));
  ASSERT_EQ(emcys(0, ms(500)).size(), 1u);
  bus.inject(F(0x000, {0x81, 0x10}));
  bus.run_until(ms(1000));
  const std::vector<CanFrame> again = emcys(ms(500), ms(1000));
  ASSERT_EQ(again.size(), 1u) << ::testing::PrintToString(again);
  EXPECT_EQ(again[0].data[0] | again[0].data[1] << 8, 0x5030);
}

// ---- an idle node does not evaluate its sensor; its checks still see
// every change on their grid (every 100 ms from the reset)

physics::Sensor& sensor_of(Application& app) {
  auto& generic = static_cast<personalities::generic::GenericApplication&>(app);
  return static_cast<personalities::SensorSource&>(generic.chain().source()).sensor();
}

TEST(Generic, AnIdleNodeDoesNotEvaluateItsSensor) {
  config::Profile p = load_repo_profile("generic-404");
  SimBus bus;
  auto app = personalities::make_application(p, {7, 0, "vcan0/g", {}});
  SimNode& n = bus.add(p, 0x10, app.get());
  bus.power_on_all();
  bus.run_until(ms(60'000));  // pre-operational: heartbeats only
  EXPECT_LT(sensor_of(*app).last().pressure.sample_index, 1000) << "sampled after the first second";
  const float bar = read_f(n, 0x6130, 1, bus.now());  // an SDO read evaluates it
  EXPECT_GT(bar, 4.0f);
  EXPECT_LT(bar, 6.0f);
  EXPECT_EQ(sensor_of(*app).last().pressure.sample_index, 60'000);
}

TEST_F(GenericFaults, AProfileFaultIsSignalledAtItsStartWhileTheNodeIsIdle) {
  start("[{kind: open, after: 1 s, duration: 2 s}]");
  bus.run_until(ms(3500));
  std::vector<TimeUs> at;
  for (const Sent& s : bus.log())
    if (s.frame.id == 0x90) at.push_back(s.time);
  EXPECT_EQ(at, (std::vector<TimeUs>{ms(1000), ms(3000)}));  // raised, then the error reset
}

// A step beyond the span between two checks: the range EMCY at the next.
TEST_F(GenericFaults, AStepBeyondTheSpanIsSignalledAtTheNextCheck) {
  start("[]");
  bus.run_until(ms(10'050));
  ASSERT_EQ(emcys(0, ms(10'050)), std::vector<CanFrame>{});
  auto* control = personalities::measurement_control(app.get());
  ASSERT_TRUE(control->step(sim->node(), physics::Channel::Pressure, 14e5, bus.now()));
  bus.run_until(ms(10'300));
  std::vector<TimeUs> at;
  for (const Sent& s : bus.log())
    if (s.frame.id == 0x90) at.push_back(s.time);
  EXPECT_EQ(at, std::vector<TimeUs>{ms(10'100)});
}

// A ramp through the span end (crossing at 5.975 s): the range EMCY at the
// first check that sees it, 6.0 s.
TEST_F(GenericFaults, ARampIsSignalledAtTheFirstCheckBeyondTheSpan) {
  start("[]");
  bus.run_until(ms(1000));
  auto* control = personalities::measurement_control(app.get());
  ASSERT_TRUE(control->ramp(sim->node(), physics::Channel::Pressure, 15.05e5, 10.0, bus.now()));
  bus.run_until(ms(8000));
  std::vector<TimeUs> at;
  for (const Sent& s : bus.log())
    if (s.frame.id == 0x90) at.push_back(s.time);
  EXPECT_EQ(at, std::vector<TimeUs>{ms(6000)});
}

// A fault armed at run time between two checks (a drift of 60 bar/s: 8 bar
// at 2.1 s, 14 bar at 2.2 s): the range EMCY at the first check beyond.
TEST_F(GenericFaults, AFaultArmedAtRunTimeIsSeenByTheNextChecks) {
  start("[]");
  bus.run_until(ms(2050));
  physics::FaultSpec drift;
  drift.kind = physics::FaultKind::Drift;
  drift.drift_per_s = 60e5;
  auto* control = personalities::measurement_control(app.get());
  ASSERT_NE(control->arm_fault(sim->node(), drift, bus.now()), physics::kInvalidFaultHandle);
  bus.run_until(ms(2300));
  std::vector<TimeUs> at;
  for (const Sent& s : bus.log())
    if (s.frame.id == 0x90) at.push_back(s.time);
  EXPECT_EQ(at, std::vector<TimeUs>{ms(2200)});
}

}  // namespace
}  // namespace cansim::test
