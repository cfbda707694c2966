// Test support for the Danfoss DST P92C personality: one node of
// profiles/p92c.yaml (node-ID 1, 125 kbit/s) on a SimBus, measuring a
// FakeSource the test sets (default 1 bar, 25 degC), and a "master" that
// injects frames and collects the node's answers.
#pragma once

#include <gtest/gtest.h>

#include "cia404_support.hpp"
#include "personalities/p92c.hpp"

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

class P92cFixture : public ::testing::Test {
 public:
  void SetUp() override {
    profile = load_repo_profile("p92c");
    personalities::prepare_profile(profile);
    auto prepared = std::static_pointer_cast<const personalities::PreparedProfile>(profile.prepared);
    auto src = std::make_unique<P92cSource>();
    source = src.get();
    source->pressure = [](TimeUs) { return 1.0e5; };
    source->temperature = [](TimeUs) { return 298.15; };
    app = std::make_unique<personalities::p92c::P92cApplication>(
        prepared->cia404, std::move(src), *std::static_pointer_cast<const personalities::p92c::Settings>(prepared->device),
        prepared->identity, 0);
    sim = &bus.add(profile, 1, app.get());
  }

  Node& node() { return sim->node(); }
  TimeUs now() const { return bus.now(); }
  void boot() {
    bus.power_on_all();
    bus.run_for(ms(1));
  }
  // Simulated power cycle: a new Node object with the same storage.
  void power_cycle() {
    sim->replace(1);
    node().power_on(now());
    bus.run_for(ms(1));
  }
  // Frames sent by the node between now and now + dt.
  std::vector<Sent> run(TimeUs dt) {
    bus.take();
    bus.run_for(dt);
    return bus.take();
  }
  // Injects a master frame and returns what the node sent within 1 ms.
  std::vector<Sent> send(const CanFrame& f, TimeUs settle = ms(1)) {
    bus.take();
    bus.inject(f);
    bus.run_for(settle);
    return bus.take();
  }
  std::vector<Sent> sdo(std::initializer_list<std::uint8_t> b, std::uint8_t id = 1) {
    CanFrame f = F(0x600u + id, b);
    f.dlc = 8;
    return send(f);
  }
  std::vector<Sent> nmt(std::uint8_t cs, std::uint8_t target = 0) { return send(F(0x000, {cs, target})); }
  std::vector<Sent> lss(std::initializer_list<std::uint8_t> b) {
    CanFrame f = F(0x7E5, b);
    f.dlc = 8;
    return send(f);
  }
  // Expedited SDO helpers (node-ID `id`): the answer frame, or an empty frame.
  CanFrame answer(const std::vector<Sent>& s, std::uint32_t id) {
    for (const Sent& x : s)
      if (x.frame.id == id) return x.frame;
    return CanFrame{};
  }
  std::uint32_t upload(std::uint16_t index, std::uint8_t sub, std::uint8_t id = 1) {
    CanFrame a = answer(sdo({0x40, std::uint8_t(index), std::uint8_t(index >> 8), sub}, id), 0x580u + id);
    EXPECT_NE(a.data[0], 0x80) << std::hex << "abort " << get_u32(a.data + 4) << " reading " << index << ":" << int(sub);
    return get_u32(a.data + 4);
  }
  std::uint32_t abort_of(const std::vector<Sent>& s, std::uint8_t id = 1) {
    CanFrame a = answer(s, 0x580u + id);
    return a.data[0] == 0x80 ? get_u32(a.data + 4) : 0;
  }
  std::uint32_t download(std::uint16_t index, std::uint8_t sub, std::uint32_t v, int size, std::uint8_t id = 1) {
    const std::uint8_t cs = std::uint8_t(0x23 | ((4 - size) << 2));
    return abort_of(sdo({cs, std::uint8_t(index), std::uint8_t(index >> 8), sub, std::uint8_t(v), std::uint8_t(v >> 8),
                         std::uint8_t(v >> 16), std::uint8_t(v >> 24)},
                        id),
                    id);
  }
  static std::vector<Sent> only(const std::vector<Sent>& s, std::uint32_t id) {
    std::vector<Sent> out;
    for (const Sent& x : s)
      if (x.frame.id == id) out.push_back(x);
    return out;
  }

  config::Profile profile;
  SimBus bus;
  P92cSource* source = nullptr;
  std::unique_ptr<personalities::p92c::P92cApplication> app;
  SimNode* sim = nullptr;
};

inline CanFrame F8(std::uint32_t id, std::initializer_list<std::uint8_t> b) {
  CanFrame f = F(id, b);
  f.dlc = 8;
  return f;
}

}  // namespace cansim::test
