// YAML physics / sensor / faults sections -> physics specs, and errors that
// name file:line:key.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <variant>

#include "config/physics_config.hpp"

namespace cansim::config {
namespace {

using namespace cansim::physics;
using ::testing::HasSubstr;

// The physics of a minimal profile with these sections.
PhysicsConfig physics_of(const std::string& sections) {
  std::string text = "name: t\nobjects:\n  - {index: 0x1000, type: UNSIGNED32, access: ro, default: 0}\n" + sections;
  return parse_profile(text, "t.yaml").physics;
}

std::string error_of(const std::string& sections) {
  try {
    physics_of(sections);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(PhysicsConfig, QuantitiesInUnits) {
  Where w{"t.yaml", "x"};
  EXPECT_DOUBLE_EQ(get_quantity(w, YAML::Load("5 bar"), Dim::kPressure), 5.0e5);
  EXPECT_DOUBLE_EQ(get_quantity(w, YAML::Load("1 psi"), Dim::kPressure), 6894.757293168361);
  EXPECT_DOUBLE_EQ(get_quantity(w, YAML::Load("250"), Dim::kPressure), 250.0);
  EXPECT_DOUBLE_EQ(get_quantity(w, YAML::Load("20 degC"), Dim::kTemperature), 293.15);
  EXPECT_DOUBLE_EQ(get_quantity(w, YAML::Load("9 degF"), Dim::kTemperatureDelta), 5.0);
  EXPECT_DOUBLE_EQ(get_quantity(w, YAML::Load("10 ms"), Dim::kTime), 0.01);
  EXPECT_DOUBLE_EQ(get_quantity(w, YAML::Load("1500 rpm"), Dim::kFrequency), 25.0);
  EXPECT_DOUBLE_EQ(get_quantity(w, YAML::Load("5 %"), Dim::kNumber), 0.05);
}

TEST(PhysicsConfig, DefaultsWhenSectionsAreAbsent) {
  PhysicsConfig c = physics_of((""));
  ASSERT_EQ(c.process.pressure.size(), 2u);
  EXPECT_DOUBLE_EQ(std::get<ConstantSpec>(c.process.pressure[0]).value, 5.0e5);
  EXPECT_DOUBLE_EQ(c.sensor.pressure.range_max, 10.0e5);
  EXPECT_TRUE(c.faults.empty());
}

TEST(PhysicsConfig, TermsSensorAndFaults) {
  PhysicsConfig c = physics_of((R"(
physics:
  pressure:
    - constant: 2 bar
    - sine: {amplitude: 100 mbar, period: 4 s}
    - ramp: {from: 0 bar, to: 1 bar, start: 1 s, duration: 10 s}
  temperature:
    - constant: 25 degC
    - ou: {sigma: 9 degF, tau: 1 min}
sensor:
  pressure: {range: [0 bar, 16 bar], sample_rate: 500 Hz, noise: 1 mbar, filter: {type: moving_average, time: 10 ms}, overload_safe: 40 bar}
  temperature: {range: [-40 degC, 125 degC], adc: 12}
faults:
  - {kind: stuck, channel: pressure, at: 10 s, duration: 5 s, value: 3 bar}
  - {kind: drift, channel: temperature, after: 1 min, drift: 0.1 K}
)"));
  EXPECT_DOUBLE_EQ(std::get<ConstantSpec>(c.process.pressure[0]).value, 2.0e5);
  EXPECT_DOUBLE_EQ(std::get<SineSpec>(c.process.pressure[1]).amplitude, 1.0e4);
  EXPECT_DOUBLE_EQ(std::get<SineSpec>(c.process.pressure[1]).frequency_hz, 0.25);
  EXPECT_DOUBLE_EQ(std::get<RampSpec>(c.process.pressure[2]).duration_s, 10.0);
  EXPECT_DOUBLE_EQ(std::get<ConstantSpec>(c.process.temperature[0]).value, 298.15);
  // Later temperature terms are differences: 9 degF = 5 K, no zero shift.
  EXPECT_DOUBLE_EQ(std::get<OrnsteinUhlenbeckSpec>(c.process.temperature[1]).sigma, 5.0);
  EXPECT_DOUBLE_EQ(std::get<OrnsteinUhlenbeckSpec>(c.process.temperature[1]).tau_s, 60.0);
  EXPECT_DOUBLE_EQ(c.sensor.pressure.range_max, 16.0e5);
  EXPECT_DOUBLE_EQ(c.sensor.pressure.sample_rate_hz, 500.0);
  EXPECT_EQ(c.sensor.pressure.filter.type, FilterType::MovingAverage);
  EXPECT_EQ(c.sensor.pressure.filter.length, 5u);
  EXPECT_DOUBLE_EQ(c.sensor.pressure.overload.safe_max, 40.0e5);
  EXPECT_DOUBLE_EQ(c.sensor.temperature.range_min, 233.15);
  ASSERT_EQ(c.faults.size(), 2u);
  EXPECT_EQ(c.faults[0].kind, FaultKind::StuckValue);
  EXPECT_EQ(*c.faults[0].timing.at_us, 10'000'000);
  EXPECT_EQ(c.faults[0].timing.duration_us, 5'000'000);
  EXPECT_DOUBLE_EQ(c.faults[0].stuck_value, 3.0e5);
  EXPECT_EQ(c.faults[1].channel, FaultChannel::Temperature);
  EXPECT_EQ(c.faults[1].timing.after_us, 60'000'000);
}

TEST(PhysicsConfig, ErrorsNameFileLineAndKey) {
  EXPECT_EQ(error_of("physics:\n  pressure:\n    - constant: 5 parsec\n"),
            "t.yaml:6:17: physics.pressure[0].constant: expected a pressure like '5 bar' (Pa, hPa, kPa, MPa, bar, "
            "mbar, psi, atm, at, mmHg), got '5 parsec'");
  EXPECT_THAT(error_of("physics:\n  pressure:\n    - wobble: 1\n"),
              HasSubstr("t.yaml:6:15: physics.pressure[0].wobble: unknown process term 'wobble'"));
  EXPECT_THAT(error_of("sensor:\n  pressure: {range: [10 bar, 1 bar]}\n"),
              HasSubstr("t.yaml:5:30: sensor.pressure.range[1]: expected max > min"));
  EXPECT_THAT(error_of("sensor:\n  pressure: {filter: {type: kalman}}\n"),
              HasSubstr("t.yaml:5:29: sensor.pressure.filter.type: expected none"));
  EXPECT_THAT(error_of("sensor:\n  temperature: {noise: 1 bar}\n"),
              HasSubstr("t.yaml:5:24: sensor.temperature.noise: expected a temperature difference"));
  EXPECT_THAT(error_of("faults:\n  - {kind: gremlins}\n"),
              HasSubstr("t.yaml:5:12: faults[0].kind: expected open, short"));
  EXPECT_THAT(error_of("faults:\n  - {kind: bus_off, at: 1 s, duration: 0 s}\n"),
              HasSubstr("faults[0].duration: expected a duration > 0 (omit it: until the end)"));
  EXPECT_EQ(error_of("faults:\n  - {kind: power_cycle, at: 1 s, duration: 0 s}\n"), "no error");
  EXPECT_THAT(error_of("faults:\n  - {kind: stuck, colour: red}\n"),
              HasSubstr("t.yaml:5:19: faults[0].colour: unknown key"));
  EXPECT_THAT(error_of("physics:\n  pressure:\n    - ou: {tau: 0 s}\n"),
              HasSubstr("physics.pressure[0].ou.tau: expected a correlation time > 0"));
}

}  // namespace
}  // namespace cansim::config
