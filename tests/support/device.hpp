// Test support for the device personalities: a profile of profiles/ prepared
// by its personality, and a node running the personality's real application
// on a SimBus. The device support headers (tests/unit/<device>_support.hpp)
// build on it; the measurement source is the test's (a fake with settable
// values) or the profile's physics (make_application).
#pragma once

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <functional>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "personalities/registry.hpp"
#include "support/sim.hpp"

namespace cansim::test {

// profiles/<name>.yaml as loaded. `edit` may change the typed profile
// (options, the personality's settings); the options are copied for it.
config::Profile prepared_repo_profile(const std::string& name, const std::function<void(config::Profile&)>& edit = {});
// The same with an edit of the file's YAML document (physics, options, ...).
config::Profile prepared_repo_yaml(const std::string& name, const std::function<void(YAML::Node&)>& edit);

// The message of the config::ConfigError loading `text` as file `file` throws, or "no error".
std::string load_error(const std::string& text, const std::string& file = "t.yaml");
// The same for profiles/<name>.yaml with an edit of its YAML document.
std::string repo_yaml_error(const std::string& name, const std::function<void(YAML::Node&)>& edit);

// A frame with DLC 8 (SDO and LSS requests are zero-padded to 8 bytes).
inline CanFrame F8(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  CanFrame f = F(id, bytes);
  f.dlc = 8;
  return f;
}
// The frames with CAN-ID id.
std::vector<Sent> only(const std::vector<Sent>& frames, std::uint32_t id);
// The first frame with CAN-ID id, or an empty frame.
CanFrame answer(const std::vector<Sent>& frames, std::uint32_t id);
// The frames without their times.
std::vector<CanFrame> frames(const std::vector<Sent>& sent);
// Expected frames: one frame; the SDO abort / download confirmation of node node_id.
inline std::vector<CanFrame> one(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) { return {F(id, bytes)}; }
std::vector<CanFrame> sdo_aborted(std::uint8_t node_id, std::uint16_t index, std::uint8_t sub, std::uint32_t code);
std::vector<CanFrame> sdo_confirmed(std::uint8_t node_id, std::uint16_t index, std::uint8_t sub);
// An expected trace (as to_string prints it): each frame at t0 + dt.
struct At {
  TimeUs dt;
  CanFrame frame;
};
std::string expected(TimeUs t0, std::initializer_list<At> list);
// The little-endian INTEGER32 at data[at].
inline std::int32_t le32(const CanFrame& f, int at = 0) {
  return std::int32_t(std::uint32_t(f.data[at]) | std::uint32_t(f.data[at + 1]) << 8 |
                      std::uint32_t(f.data[at + 2]) << 16 | std::uint32_t(f.data[at + 3]) << 24);
}

// One node of a device profile running App (the personality's application),
// which measures a Source the test sets (source stays valid while app lives).
template <class App, class Source>
class DeviceFixture : public ::testing::Test {
 public:
  Node& node() { return sim->node(); }
  TimeUs now() const { return bus.now(); }
  // Power-on of every node on the bus, then `settle` of bus time.
  void power_on(TimeUs settle) {
    bus.power_on_all();
    bus.run_for(settle);
  }
  // Simulated power cycle: a new Node object (the application reboots with
  // it), same storage and application; then `settle` of bus time.
  void power_cycle(TimeUs settle = 0) {
    sim->replace(id);
    node().power_on(now());
    if (settle > 0) bus.run_for(settle);
  }
  // A master frame (delivered at once; the bus does not run).
  void master(std::uint32_t can_id, std::initializer_list<std::uint8_t> bytes) { bus.inject(F(can_id, bytes)); }
  void sync() { bus.inject(CanFrame::make(0x080, {})); }
  // The stored value (no read hook).
  std::uint64_t u(std::uint16_t index, std::uint8_t sub) { return node().values().u(index, sub); }

  SimBus bus;
  config::Profile profile;
  Source* source = nullptr;
  std::unique_ptr<App> app;
  SimNode* sim = nullptr;
  std::uint8_t id = 0;  // the node's node-ID on the bus

 protected:
  // profiles/<name>.yaml (prepared_repo_profile: `edit` comes first) and the
  // node `node_id` (0: the profile's) running the App that `make` builds from
  // the profile around a new Source.
  template <class Make>
  void build_node(const std::string& name, std::uint8_t node_id, Make make,
                  const std::function<void(config::Profile&)>& edit = {}) {
    profile = prepared_repo_profile(name, edit);
    auto src = std::make_unique<Source>();
    source = src.get();
    app = make(profile, std::move(src));
    id = node_id ? node_id : profile.node_id;
    sim = &bus.add(profile, id, app.get());
  }
  // The usual application constructor: App(chain, source, device settings, node index 0).
  template <class Settings>
  static std::unique_ptr<App> device_app(const config::Profile& p, std::unique_ptr<Source> src) {
    return std::make_unique<App>(p.cia404, std::move(src), std::get<Settings>(p.device), 0);
  }
};

// DeviceFixture with a master that answers for itself: each request returns
// what the node sent within `settle` after it (the log is emptied before).
template <class App, class Source>
class DeviceMasterFixture : public DeviceFixture<App, Source> {
 public:
  // Frames sent by the node between now and now + dt.
  std::vector<Sent> run(TimeUs dt) {
    this->bus.take();
    this->bus.run_for(dt);
    return this->bus.take();
  }
  std::vector<Sent> send(const CanFrame& f, TimeUs settle = ms(1)) {
    this->bus.take();
    this->bus.inject(f);
    this->bus.run_for(settle);
    return this->bus.take();
  }
  std::vector<Sent> sdo(std::initializer_list<std::uint8_t> b) { return sdo(b, this->id); }
  std::vector<Sent> sdo(std::initializer_list<std::uint8_t> b, std::uint8_t node_id) {
    return send(F8(0x600u + node_id, b));
  }
  std::vector<Sent> nmt(std::uint8_t cs, std::uint8_t target = 0, TimeUs settle = ms(1)) {
    return send(F(0x000, {cs, target}), settle);
  }
  std::vector<Sent> lss(std::initializer_list<std::uint8_t> b) { return send(F8(0x7E5, b)); }

  // Expedited upload: the 4 data bytes as a number (an abort fails the test).
  std::uint32_t upload(std::uint16_t index, std::uint8_t sub) { return upload(index, sub, this->id); }
  std::uint32_t upload(std::uint16_t index, std::uint8_t sub, std::uint8_t node_id) {
    const CanFrame a =
        answer(sdo({0x40, std::uint8_t(index), std::uint8_t(index >> 8), sub}, node_id), 0x580u + node_id);
    EXPECT_NE(a.data[0], 0x80) << std::hex << "abort " << get_u32(a.data + 4) << " reading " << index << ":"
                               << int(sub);
    return get_u32(a.data + 4);
  }
  // The abort code the node answered with, or 0.
  std::uint32_t abort_of(const std::vector<Sent>& s) { return abort_of(s, this->id); }
  std::uint32_t abort_of(const std::vector<Sent>& s, std::uint8_t node_id) {
    const CanFrame a = answer(s, 0x580u + node_id);
    return a.data[0] == 0x80 ? get_u32(a.data + 4) : 0;
  }
  // Expedited download with size indication (size 1, 2 or 4): the abort code, or 0.
  std::uint32_t download(std::uint16_t index, std::uint8_t sub, std::uint32_t v, int size) {
    return download(index, sub, v, size, this->id);
  }
  std::uint32_t download(std::uint16_t index, std::uint8_t sub, std::uint32_t v, int size, std::uint8_t node_id) {
    const std::uint8_t cs = std::uint8_t(0x23 | ((4 - size) << 2));
    return abort_of(sdo({cs, std::uint8_t(index), std::uint8_t(index >> 8), sub, std::uint8_t(v), std::uint8_t(v >> 8),
                         std::uint8_t(v >> 16), std::uint8_t(v >> 24)},
                        node_id),
                    node_id);
  }
};

}  // namespace cansim::test
