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
#include "support/sim.hpp"

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

class DpsFixture : public ::testing::Test {
 public:
  static constexpr std::uint8_t kId = 0x7F;

  // `edit` may change the profile (options, vendor settings) before it is prepared.
  void build(const std::function<void(config::Profile&)>& edit = {}) {
    profile = load_repo_profile("dps");
    if (edit) {
      profile.options = std::make_shared<NodeOptions>(*profile.options);
      edit(profile);
    }
    personalities::prepare_profile(profile);
    prepared = std::static_pointer_cast<const personalities::PreparedProfile>(profile.prepared);
    make_app();
    sim = &bus.add(profile, profile.node_id, app.get());
  }
  // Boots and leaves the node pre-operational with an empty log.
  void boot() {
    bus.power_on_all();
    bus.run_for(ms(1));
    bus.take();
  }
  void SetUp() override { build(); }

  // Simulated power cycle: new Node (the Application reboots with it), same storage.
  void power_cycle() {
    sim->replace(kId);
    sim->node().power_on(bus.now());
  }

  Node& node() { return sim->node(); }
  void master(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) { bus.inject(F(id, bytes)); }
  void nmt(std::uint8_t cs, std::uint8_t id = kId) { master(0x000, {cs, id}); }
  void sync() { bus.inject(CanFrame::make(0x080, {})); }
  // One SDO request; returns what the node sent within 1 ms.
  std::vector<Sent> sdo(std::initializer_list<std::uint8_t> bytes, std::uint8_t id = kId) {
    master(0x600u + id, bytes);
    bus.run_for(ms(1));
    return bus.take();
  }
  std::vector<Sent> on(std::uint32_t id) {
    std::vector<Sent> out;
    for (const Sent& s : bus.take())
      if (s.frame.id == id) out.push_back(s);
    return out;
  }
  std::int64_t i32(std::uint16_t index, std::uint8_t sub) {
    std::span<const std::uint8_t> out;
    EXPECT_EQ(node().read(index, sub, bus.now(), out), SdoAbort::kNone);
    return out.size() >= 4 ? decode_i(DataType::kInteger32, out.data()) : -1;
  }
  std::uint64_t u(std::uint16_t index, std::uint8_t sub) { return node().values().u(index, sub); }
  static std::int32_t le32(const CanFrame& f, int at = 0) {
    return std::int32_t(std::uint32_t(f.data[at]) | std::uint32_t(f.data[at + 1]) << 8 |
                        std::uint32_t(f.data[at + 2]) << 16 | std::uint32_t(f.data[at + 3]) << 24);
  }

  SimBus bus;
  config::Profile profile;
  std::shared_ptr<const personalities::PreparedProfile> prepared;
  DpsSource* source = nullptr;
  std::unique_ptr<personalities::dps::DpsApplication> app;
  SimNode* sim = nullptr;

 private:
  void make_app() {
    auto src = std::make_unique<DpsSource>();
    source = src.get();
    app = std::make_unique<personalities::dps::DpsApplication>(*prepared, std::move(src), 0);
  }
};

}  // namespace cansim::test
