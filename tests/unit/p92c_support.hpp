// Test support for the Danfoss DST P92C personality: one node of
// profiles/p92c.yaml (node-ID 1, 125 kbit/s) on a SimBus, measuring a
// FakeSource the test sets (default 1 bar, 25 degC), and a "master" that
// injects frames and collects the node's answers.
#pragma once

#include <gtest/gtest.h>

#include "cia404_support.hpp"
#include "personalities/p92c.hpp"
#include "support/device.hpp"

namespace cansim::test {

// FakeSource with a status per channel.
class P92cSource : public FakeSource {
 public:
  std::uint8_t pressure_status = 0;
  std::uint8_t temperature_status = 0;
  Sample sample(physics::Channel ch, TimeUs now) override {
    Sample s = FakeSource::sample(ch, now);
    s.status = ch == physics::Channel::Pressure ? pressure_status : temperature_status;
    return s;
  }
};

class P92cFixture : public DeviceMasterFixture<personalities::p92c::P92cApplication, P92cSource> {
 public:
  void SetUp() override {
    build_node("p92c", 1, device_app<personalities::p92c::Settings>);
    source->pressure = [](TimeUs) { return 1.0e5; };
    source->temperature = [](TimeUs) { return 298.15; };
  }

  // Power-on; the boot-up frame stays in the log.
  void boot() { power_on(ms(1)); }
  // Simulated power cycle: a new Node object with the same storage.
  void power_cycle() { DeviceFixture::power_cycle(ms(1)); }
};

}  // namespace cansim::test
