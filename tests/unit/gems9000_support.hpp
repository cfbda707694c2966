// Test support for the Gems 9000 personality: profiles/gems9000.yaml on a
// SimBus at the default node-ID 1, measuring a source whose pressure (bar,
// gauge) and temperature (degC) the test sets. Default scenario of the spec
// (§12): P = 0.002 bar, T = 22.5 degC.
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <memory>

#include "personalities/gems9000.hpp"
#include "support/device.hpp"

namespace cansim::test {

class GemsSource : public personalities::MeasurementSource {
 public:
  double bar = 0.002;
  double degc = 22.5;
  std::uint8_t status = 0;  // pressure channel status (physics kStatus* bits)
  Sample sample(physics::Channel ch, TimeUs) override {
    if (ch == physics::Channel::Pressure) return {bar * 1e5, std::int32_t(bar * 6000), status};
    return {degc + 273.15, std::int32_t((degc + 40) * 500), 0};
  }
  TimeUs sample_period_us(physics::Channel) const override { return 10000; }
};

class GemsFixture : public DeviceFixture<personalities::gems9000::GemsApplication, GemsSource> {
 public:
  static constexpr std::uint8_t kId = 1;
  static constexpr std::uint32_t kPin = 0x00001234;  // profile placeholder

  void build(const std::function<void(config::Profile&)>& edit = {}) {
    build_node("gems9000", 0, device_app<personalities::gems9000::Settings>, edit);
  }
  void SetUp() override { build(); }

  // Power-on; leaves the node pre-operational with an empty log.
  void boot() {
    power_on(ms(1));
    bus.take();
  }

  void nmt(std::uint8_t cs, std::uint8_t id = kId) { master(0x000, {cs, id}); }
  // One request to 0x600+id; what the node sent within 1 ms.
  std::vector<CanFrame> sdo(std::initializer_list<std::uint8_t> bytes, std::uint8_t id = kId) {
    master(0x600u + id, bytes);
    return frames_for(ms(1));
  }
  std::vector<CanFrame> frames_for(TimeUs dt) {
    bus.run_for(dt);
    return frames(bus.take());
  }
  // Expedited write (0x22, as in every manual figure); true when confirmed.
  bool write32(std::uint16_t index, std::uint8_t sub, std::uint32_t v) {
    auto out = sdo({0x22, std::uint8_t(index), std::uint8_t(index >> 8), sub, std::uint8_t(v), std::uint8_t(v >> 8),
                    std::uint8_t(v >> 16), std::uint8_t(v >> 24)});
    return out.size() == 1 && out[0].data[0] == 0x60;
  }
  bool write_real(std::uint16_t index, std::uint8_t sub, float f) {
    std::uint32_t v = 0;
    std::memcpy(&v, &f, 4);
    return write32(index, sub, v);
  }
  // Value read through the node (as SDO would, hooks included).
  float real(std::uint16_t index, std::uint8_t sub) {
    std::span<const std::uint8_t> out;
    EXPECT_EQ(node().read(index, sub, bus.now(), out), SdoAbort::kNone);
    return out.size() >= 4 ? float(decode_f(DataType::kReal32, out.data())) : -1e30f;
  }
  std::int64_t i16(std::uint16_t index, std::uint8_t sub) {
    std::span<const std::uint8_t> out;
    EXPECT_EQ(node().read(index, sub, bus.now(), out), SdoAbort::kNone);
    return out.size() >= 2 ? decode_i(DataType::kInteger16, out.data()) : -99999;
  }
  void start() {
    nmt(0x01);
    bus.run_for(ms(1));
    bus.take();
  }

  static std::vector<CanFrame> aborted(std::uint16_t index, std::uint8_t sub, std::uint32_t code) {
    return sdo_aborted(kId, index, sub, code);
  }
  static std::vector<CanFrame> confirmed(std::uint16_t index, std::uint8_t sub) {
    return sdo_confirmed(kId, index, sub);
  }
};

}  // namespace cansim::test
