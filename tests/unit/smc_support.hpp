// Test support for the ADZ NAGANO SMC personality: one node of
// profiles/smc.yaml (node-ID 0x20, 125 kbit/s) on a SimBus, measuring a source
// whose field values (0..20000 counts per channel) the test sets, and a
// "master" that injects frames and collects the node's answers.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "cia404_support.hpp"
#include "personalities/smc.hpp"
#include "support/device.hpp"

namespace cansim::test {

// Field values per channel; the SI value is derived through the profile's ranges.
class SmcSource : public personalities::MeasurementSource {
 public:
  double fv[2] = {10000.0, 8888.9};  // 2.5 bar, 25 degC
  std::uint8_t status[2] = {};
  double range_min[2] = {};
  double range_max[2] = {};
  Sample sample(physics::Channel ch, TimeUs) override {
    const int i = ch == physics::Channel::Pressure ? 0 : 1;
    return {range_min[i] + fv[i] / 20000.0 * (range_max[i] - range_min[i]), std::int32_t(std::lround(fv[i])),
            status[i]};
  }
  TimeUs sample_period_us(physics::Channel) const override { return 1000; }
};

class SmcFixture : public DeviceMasterFixture<personalities::smc::SmcApplication, SmcSource> {
 public:
  static constexpr std::uint8_t kId = 0x20;

  void SetUp() override {
    build_node("smc", kId, device_app<personalities::smc::Settings>);
    const auto& settings = std::get<personalities::smc::Settings>(profile.device);
    for (int i = 0; i < 2; ++i) {
      source->range_min[i] = settings.range_min[i];
      source->range_max[i] = settings.range_max[i];
    }
  }

  // Power-on and the boot-up (boot_up_delay_ms = 150).
  void boot() {
    power_on(ms(200));
    bus.take();
  }
  void power_cycle() { DeviceFixture::power_cycle(ms(200)); }
  float upload_f(std::uint16_t index, std::uint8_t sub) {
    const std::uint32_t u = upload(index, sub);
    float f;
    std::memcpy(&f, &u, 4);
    return f;
  }
  std::uint32_t download_f(std::uint16_t index, std::uint8_t sub, float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return download(index, sub, u, 4);
  }
};

}  // namespace cansim::test
