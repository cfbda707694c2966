// Test support for the Honeywell DPS personality: profiles/dps.yaml on a
// SimBus at node-ID 0x7F whose pressure the test sets (psi), with the 12-bit
// raw counts of the profile's sensor (0..4095 over -5..105 psi).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>

#include "personalities/dps.hpp"
#include "support/device.hpp"

namespace cansim::test {

constexpr double kPaPerPsi = 6894.757293168361;

class DpsSource : public personalities::MeasurementSource {
 public:
  double psi = 50.0;
  std::uint8_t status = 0;
  Sample sample(physics::Channel, TimeUs) override {
    const double raw = std::round((psi + 5.0) / 110.0 * 4095.0);
    return {psi * kPaPerPsi, std::int32_t(std::clamp(raw, 0.0, 4095.0)), status};
  }
  TimeUs sample_period_us(physics::Channel) const override { return 1000; }
};

class DpsFixture : public DeviceFixture<personalities::dps::DpsApplication, DpsSource> {
 public:
  static constexpr std::uint8_t kId = 0x7F;

  // `edit` may change the profile (options, vendor settings) before it is prepared.
  void build(const std::function<void(config::Profile&)>& edit = {}) { build_node("dps", 0, make_app, edit); }
  // Boots and leaves the node pre-operational with an empty log.
  void boot() {
    power_on(ms(1));
    bus.take();
  }
  void SetUp() override { build(); }

  void nmt(std::uint8_t cs, std::uint8_t id = kId) { master(0x000, {cs, id}); }
  // One SDO request; returns what the node sent within 1 ms.
  std::vector<Sent> sdo(std::initializer_list<std::uint8_t> bytes, std::uint8_t id = kId) {
    master(0x600u + id, bytes);
    bus.run_for(ms(1));
    return bus.take();
  }
  std::vector<Sent> on(std::uint32_t id) { return only(bus.take(), id); }
  std::int64_t i32(std::uint16_t index, std::uint8_t sub) {
    std::span<const std::uint8_t> out;
    EXPECT_EQ(node().read(index, sub, bus.now(), out), SdoAbort::kNone);
    return out.size() >= 4 ? decode_i(DataType::kInteger32, out.data()) : -1;
  }

 private:
  static std::unique_ptr<personalities::dps::DpsApplication> make_app(const config::Profile& p,
                                                                      std::unique_ptr<DpsSource> src) {
    return std::make_unique<personalities::dps::DpsApplication>(p.cia404, std::move(src),
                                                                std::get<personalities::dps::Settings>(p.device), 0);
  }
};

}  // namespace cansim::test
