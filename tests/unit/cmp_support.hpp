// Test support for the trafag-cmp personality: nodes of profiles/cmp.yaml
// with their real application on a SimBus. The physics can be replaced per
// test (constant / ramp / table pressure, no noise) for exact expectations.
#pragma once

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "personalities/registry.hpp"
#include "support/device.hpp"

namespace cansim::test {

// The CMP profile with an edit of its YAML document (physics, options, ...).
inline config::Profile cmp_profile(const std::function<void(YAML::Node&)>& edit = {}) {
  return prepared_repo_yaml("cmp", edit);
}

// Noise-free sensor and a process given as YAML (e.g. "5 bar").
inline std::function<void(YAML::Node&)> quiet(const std::string& pressure = "5 bar",
                                              const std::string& temperature = "25 degC") {
  return [=](YAML::Node& root) {
    root["physics"]["pressure"] = YAML::Load(pressure);
    root["physics"]["temperature"] = YAML::Load(temperature);
    root["sensor"]["pressure"]["noise"] = 0;
    root["sensor"]["temperature"]["noise"] = 0;
  };
}

class CmpBus {
 public:
  explicit CmpBus(config::Profile p) : profile(std::move(p)) {}

  SimNode& add(std::uint8_t node_id, std::uint32_t index = 0) {
    personalities::NodeContext ctx;
    ctx.index = index;
    ctx.key = "vcan0/cmp-" + std::to_string(node_id);
    apps.push_back(personalities::make_application(profile, ctx));
    SimNode& n = bus.add(profile, node_id, apps.back().get());
    return n;
  }
  // Powers every node on and lets the boot-up frames go out.
  void boot() {
    bus.power_on_all();
    bus.run_for(ms(1));
  }

  // Master frames.
  void nmt(std::uint8_t cs, std::uint8_t id) { bus.inject(F(0x000, {cs, id})); }
  std::vector<Sent> sdo(std::uint8_t id, std::initializer_list<std::uint8_t> bytes) {
    bus.take();
    bus.inject(F(0x600u + id, bytes));
    bus.run_for(ms(1));
    return bus.take();
  }
  // Expedited download; returns the answer frame data (empty when none).
  CanFrame download(std::uint8_t id, std::uint16_t index, std::uint8_t sub, std::uint32_t value) {
    auto out = sdo(id, {0x22, std::uint8_t(index), std::uint8_t(index >> 8), sub, std::uint8_t(value),
                        std::uint8_t(value >> 8), std::uint8_t(value >> 16), std::uint8_t(value >> 24)});
    return out.empty() ? CanFrame{} : out.front().frame;
  }
  CanFrame upload(std::uint8_t id, std::uint16_t index, std::uint8_t sub) {
    auto out = sdo(id, {0x40, std::uint8_t(index), std::uint8_t(index >> 8), sub, 0, 0, 0, 0});
    return out.empty() ? CanFrame{} : out.front().frame;
  }
  // Segmented download of up to 8 bytes (special messages).
  void download_long(std::uint8_t id, std::uint16_t index, std::uint8_t sub, std::vector<std::uint8_t> data) {
    auto n = std::uint8_t(data.size());
    auto init = sdo(id, {0x21, std::uint8_t(index), std::uint8_t(index >> 8), sub, n, 0, 0, 0});
    ASSERT_EQ(init.size(), 1u);
    ASSERT_EQ(init[0].frame.data[0], 0x60);
    std::size_t at = 0;
    std::uint8_t toggle = 0;
    while (at < data.size()) {
      const std::size_t chunk = std::min<std::size_t>(7, data.size() - at);
      CanFrame f = F(0x600u + id, {});
      f.dlc = 8;
      f.data[0] = std::uint8_t(toggle | ((7 - chunk) << 1) | (at + chunk == data.size() ? 1 : 0));
      std::memcpy(f.data + 1, data.data() + at, chunk);
      bus.take();
      bus.inject(f);
      bus.run_for(ms(1));
      auto ack = bus.take();
      ASSERT_EQ(ack.size(), 1u);
      ASSERT_EQ(ack[0].frame.data[0] & 0xE0, 0x20);
      at += chunk;
      toggle ^= 0x10;
    }
  }

  static std::uint32_t u32(const CanFrame& f) { return std::uint32_t(le32(f, 4)); }
  static float f32(const CanFrame& f) {
    float v;
    std::memcpy(&v, f.data + 4, 4);
    return v;
  }

  config::Profile profile;
  SimBus bus;
  std::vector<std::unique_ptr<Application>> apps;
};

}  // namespace cansim::test
