// Test support for the ADZ NAGANO SMC personality: one node of
// profiles/smc.yaml (node-ID 0x20, 125 kbit/s) on a SimBus, measuring a source
// whose field values (0..20000 counts per channel) the test sets, and a
// "master" that injects frames and collects the node's answers.
#pragma once

#include <gtest/gtest.h>

#include <cmath>

#include "cia404_support.hpp"
#include "personalities/smc.hpp"

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
    return {range_min[i] + fv[i] / 20000.0 * (range_max[i] - range_min[i]), std::int32_t(std::lround(fv[i])), status[i]};
  }
  TimeUs sample_period_us(physics::Channel) const override { return 1000; }
};

inline CanFrame F8(std::uint32_t id, std::initializer_list<std::uint8_t> b) {
  CanFrame f = F(id, b);
  f.dlc = 8;
  return f;
}

class SmcFixture : public ::testing::Test {
 public:
  static constexpr std::uint8_t kId = 0x20;

  void SetUp() override {
    profile = load_repo_profile("smc");
    personalities::prepare_profile(profile);
    auto prepared = std::static_pointer_cast<const personalities::PreparedProfile>(profile.prepared);
    const auto& settings = *std::static_pointer_cast<const personalities::smc::Settings>(prepared->device);
    auto src = std::make_unique<SmcSource>();
    source = src.get();
    for (int i = 0; i < 2; ++i) {
      source->range_min[i] = settings.range_min[i];
      source->range_max[i] = settings.range_max[i];
    }
    app = std::make_unique<personalities::smc::SmcApplication>(prepared->cia404, std::move(src), settings,
                                                                prepared->identity, 0);
    sim = &bus.add(profile, kId, app.get());
  }

  Node& node() { return sim->node(); }
  TimeUs now() const { return bus.now(); }
  // Power-on and the boot-up (boot_up_delay_ms = 150).
  void boot() {
    bus.power_on_all();
    bus.run_for(ms(200));
    bus.take();
  }
  void power_cycle() {
    sim->replace(kId);
    node().power_on(now());
    bus.run_for(ms(200));
  }
  std::vector<Sent> run(TimeUs dt) {
    bus.take();
    bus.run_for(dt);
    return bus.take();
  }
  std::vector<Sent> send(const CanFrame& f, TimeUs settle = ms(1)) {
    bus.take();
    bus.inject(f);
    bus.run_for(settle);
    return bus.take();
  }
  std::vector<Sent> sdo(std::initializer_list<std::uint8_t> b, std::uint8_t id = kId) { return send(F8(0x600u + id, b)); }
  std::vector<Sent> nmt(std::uint8_t cs, std::uint8_t target = 0, TimeUs settle = ms(1)) {
    return send(F(0x000, {cs, target}), settle);
  }
  std::vector<Sent> lss(std::initializer_list<std::uint8_t> b) { return send(F8(0x7E5, b)); }
  static CanFrame answer(const std::vector<Sent>& s, std::uint32_t id) {
    for (const Sent& x : s)
      if (x.frame.id == id) return x.frame;
    return CanFrame{};
  }
  static std::vector<Sent> only(const std::vector<Sent>& s, std::uint32_t id) {
    std::vector<Sent> out;
    for (const Sent& x : s)
      if (x.frame.id == id) out.push_back(x);
    return out;
  }
  // Expedited upload: the 4 data bytes as a number (aborts fail the test).
  std::uint32_t upload(std::uint16_t index, std::uint8_t sub, std::uint8_t id = kId) {
    CanFrame a = answer(sdo({0x40, std::uint8_t(index), std::uint8_t(index >> 8), sub}, id), 0x580u + id);
    EXPECT_NE(a.data[0], 0x80) << std::hex << "abort " << get_u32(a.data + 4) << " reading " << index << ":" << int(sub);
    return get_u32(a.data + 4);
  }
  float upload_f(std::uint16_t index, std::uint8_t sub) {
    const std::uint32_t u = upload(index, sub);
    float f;
    std::memcpy(&f, &u, 4);
    return f;
  }
  std::uint32_t abort_of(const std::vector<Sent>& s, std::uint8_t id = kId) {
    CanFrame a = answer(s, 0x580u + id);
    return a.data[0] == 0x80 ? get_u32(a.data + 4) : 0;
  }
  // Expedited download with size indication (size 1, 2 or 4); returns the abort code or 0.
  std::uint32_t download(std::uint16_t index, std::uint8_t sub, std::uint32_t v, int size, std::uint8_t id = kId) {
    const std::uint8_t cs = std::uint8_t(0x23 | ((4 - size) << 2));
    return abort_of(sdo({cs, std::uint8_t(index), std::uint8_t(index >> 8), sub, std::uint8_t(v), std::uint8_t(v >> 8),
                         std::uint8_t(v >> 16), std::uint8_t(v >> 24)},
                        id),
                    id);
  }
  std::uint32_t download_f(std::uint16_t index, std::uint8_t sub, float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return download(index, sub, u, 4);
  }

  config::Profile profile;
  SimBus bus;
  SmcSource* source = nullptr;
  std::unique_ptr<personalities::smc::SmcApplication> app;
  SimNode* sim = nullptr;
};

// Expected frames, each at t0 + dt.
struct At {
  TimeUs dt;
  CanFrame frame;
};
inline std::string expected(TimeUs t0, std::initializer_list<At> list) {
  std::vector<Sent> v;
  for (const At& a : list) v.push_back({t0 + a.dt, a.frame});
  return to_string(v);
}

}  // namespace cansim::test
