// One serial path: a fleet entry's `serial:` and a profile's
// `serial_number_base` are the node's 0x1018:04 default, applied before the
// personality's reset hook, so every vendor copy of the serial number follows
// it after power-on, reset node and reset communication.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "config/fleet.hpp"
#include "daemon/daemon.hpp"
#include "support/device.hpp"

namespace cansim::test {
namespace {

// A serial object of a personality: numeric (value = the serial) or the
// text it is part of.
struct SerialObject {
  std::uint16_t index;
  std::uint8_t sub;
  std::string text_format;  // printf format of a string object ("" for a number)
};

struct Personality {
  const char* profile;
  std::vector<SerialObject> objects;
};

const std::vector<Personality> kPersonalities = {
    {"generic-404", {{0x1018, 4, ""}}},
    {"dps", {{0x1018, 4, ""}, {0x200E, 0, ""}}},
    {"p92c", {{0x1018, 4, ""}, {0x4E00, 2, ""}, {0x4E00, 4, "11.%06u.5566"}}},
    {"gems9000", {{0x1018, 4, ""}}},
    {"smc", {{0x1018, 4, ""}, {0x4030, 1, ""}}},
    {"cmp", {{0x1018, 4, ""}}},
};

class SerialNumbers : public ::testing::TestWithParam<Personality> {
 protected:
  // The fleet: one node with `serial: 654321`, a group of two with
  // `serial_number_base: 7000` (7000, 7001).
  void SetUp() override {
    const std::string p = GetParam().profile;
    const std::string text =
        "interfaces:\n  vcan0: {}\nnodes:\n"
        "  - {profile: " +
        p +
        ", interface: vcan0, node_id: 0x20, serial: 654321}\n"
        "  - {profile: " +
        p +
        ", interface: vcan0, node_id: 0x30, count: 2,"
        " vendor: {serial_number_base: 7000}}\n";
    const std::string file = std::string(CANSIM_SOURCE_DIR) + "/serial-test.yaml";
    fleet = config::parse_fleet(text, file, config::default_search(file, ""));
    ASSERT_EQ(fleet.nodes.size(), 3u);
    for (const config::NodeConfig& n : fleet.nodes) {
      apps.push_back(daemon::make_node_application(n, 1));
      NodeSetup setup = daemon::node_setup(n, 1);
      sims.push_back(&bus.add(*n.profile, n.node_id, apps.back().get(), setup.serial_number));
    }
    bus.power_on_all();
    bus.run_for(ms(100));
  }

  // Every serial object of node `k` reads `serial` through the SDO path.
  void expect_serial(std::size_t k, std::uint32_t serial, const char* when) {
    Node& node = sims[k]->node();
    for (const SerialObject& o : GetParam().objects) {
      std::span<const std::uint8_t> bytes;
      ASSERT_EQ(node.read(o.index, o.sub, bus.now(), bytes), SdoAbort::kNone);
      const std::string where = std::string(GetParam().profile) + " node " + std::to_string(k) + " after " + when;
      if (o.text_format.empty()) {
        EXPECT_EQ(decode_u(node.od().find(o.index, o.sub)->type, bytes.data()), serial)
            << std::hex << o.index << ":" << int(o.sub) << " " << where;
      } else {
        char text[64];
        std::snprintf(text, sizeof text, o.text_format.c_str(), unsigned(serial));
        EXPECT_EQ(std::string(bytes.begin(), bytes.end()), text) << std::hex << o.index << " " << where;
      }
    }
  }
  void expect_all(const char* when) {
    expect_serial(0, 654321, when);
    expect_serial(1, 7000, when);
    expect_serial(2, 7001, when);
  }
  void nmt_all(std::uint8_t cs) {
    bus.inject(F(0x000, {cs, 0x00}));
    bus.run_for(ms(500));
  }

  config::FleetConfig fleet;
  SimBus bus;
  std::vector<std::unique_ptr<Application>> apps;
  std::vector<SimNode*> sims;
};

TEST_P(SerialNumbers, EverySerialObjectFollowsTheFleetSerialAndTheBase) {
  expect_all("power-on");
  nmt_all(0x81);
  expect_all("reset node");
  nmt_all(0x82);
  expect_all("reset communication");
  for (SimNode* s : sims) s->node().power_off(bus.now());
  for (SimNode* s : sims) s->node().power_on(bus.now());
  bus.run_for(ms(500));
  expect_all("a power cycle");
}

INSTANTIATE_TEST_SUITE_P(Personalities, SerialNumbers, ::testing::ValuesIn(kPersonalities), [](const auto& info) {
  std::string n = info.param.profile;
  for (char& c : n)
    if (c == '-') c = '_';
  return n;
});

}  // namespace
}  // namespace cansim::test
