// Registry + generic personality: profile validation errors, serial numbers
// per node, physics defaults, hooks set on the CiA 404 objects.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "personalities/registry.hpp"
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
  const std::string text = "name: t\npersonality: wizard\nobjects:\n  - {index: 0x1000, type: UNSIGNED32, access: ro}\n";
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

}  // namespace
}  // namespace cansim::test
