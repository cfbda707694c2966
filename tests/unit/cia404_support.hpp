// Test support for the CiA 404 chain: a node of the generic-404 profile on a
// SimBus whose measurement source is a function of time set by the test.
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <memory>

#include "personalities/generic.hpp"
#include "personalities/registry.hpp"
#include "support/device.hpp"
#include "support/sim.hpp"

namespace cansim::test {

class FakeSource : public personalities::MeasurementSource {
 public:
  // SI value (Pa / K) as a function of time, per channel.
  std::function<double(TimeUs)> pressure = [](TimeUs) { return 5.0e5; };
  std::function<double(TimeUs)> temperature = [](TimeUs) { return 293.15; };
  std::uint8_t status = 0;
  Sample sample(physics::Channel ch, TimeUs now) override {
    double v = ch == physics::Channel::Pressure ? pressure(now) : temperature(now);
    return {v, std::int32_t(v / 100.0), status};
  }
  TimeUs sample_period_us(physics::Channel) const override { return 1000; }
};

class ChainFixture : public ::testing::Test {
 public:
  void build(config::Profile p) {
    profile = std::move(p);
    auto src = std::make_unique<FakeSource>();
    source = src.get();
    app = std::make_unique<personalities::generic::GenericApplication>(profile.cia404, std::move(src), false);
    sim = &bus.add(profile, 0x10, app.get());
    bus.power_on_all();
    bus.run_for(ms(1));
    bus.take();
  }
  void SetUp() override { build(load_repo_profile("generic-404")); }

  Node& node() { return sim->node(); }
  TimeUs now() const { return bus.now(); }
  std::span<const std::uint8_t> read(std::uint16_t i, std::uint8_t s, SdoAbort* why = nullptr) {
    std::span<const std::uint8_t> out;
    SdoAbort a = node().read(i, s, now(), out);
    if (why) *why = a;
    EXPECT_TRUE(why || ok(a)) << std::hex << i << ":" << int(s) << " " << describe(a);
    return out;
  }
  float f(std::uint16_t i, std::uint8_t s) { return decode_f(DataType::kReal32, read(i, s).data()); }
  std::int64_t i16(std::uint16_t i, std::uint8_t s) { return decode_i(DataType::kInteger16, read(i, s).data()); }
  std::int64_t i32(std::uint16_t i, std::uint8_t s) { return decode_i(DataType::kInteger32, read(i, s).data()); }
  std::uint64_t u(std::uint16_t i, std::uint8_t s) {
    auto b = read(i, s);
    std::uint64_t v = 0;
    for (std::size_t k = 0; k < b.size() && k < 8; ++k) v |= std::uint64_t(b[k]) << (8 * k);
    return v;
  }
  SdoAbort wf(std::uint16_t i, std::uint8_t s, float v) {
    std::uint8_t b[4];
    encode_f(DataType::kReal32, v, b);
    return node().write(i, s, b, now());
  }
  SdoAbort wu32(std::uint16_t i, std::uint8_t s, std::uint32_t v) {
    std::uint8_t b[4];
    put_u32(b, v);
    return node().write(i, s, b, now());
  }
  SdoAbort wu16(std::uint16_t i, std::uint8_t s, std::uint16_t v) {
    std::uint8_t b[2];
    put_u16(b, v);
    return node().write(i, s, b, now());
  }
  SdoAbort wu8(std::uint16_t i, std::uint8_t s, std::uint8_t v) {
    std::uint8_t b[1] = {v};
    return node().write(i, s, b, now());
  }

  SimBus bus;
  config::Profile profile;
  FakeSource* source = nullptr;
  std::unique_ptr<personalities::generic::GenericApplication> app;
  SimNode* sim = nullptr;
};

}  // namespace cansim::test
