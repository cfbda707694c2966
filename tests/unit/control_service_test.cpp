// The control API's object model over a real sd-bus peer connection (a
// socketpair, no bus daemon) on the fake clock: names, properties, methods,
// argument validation and signals, checked against the frames on the bus.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>

#include "config/eds_reader.hpp"
#include "control/service.hpp"
#include "io/wire_bits.hpp"
#include "support/control_fleet.hpp"

namespace cansim::test {
namespace {

constexpr const char* kFleet = R"(
interfaces: {vcan0: {bit_rate: 250}, vcan1: {bit_rate: 250}}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 0x10, count: 3, name: generic}
  - {profile: dps, interface: vcan0, bit_rate: 250, name: dps}
  - {profile: generic-404, interface: vcan1, node_id: 0x20, name: other}
)";

constexpr TimeUs kMs = 1000;

class ControlServiceTest : public ::testing::Test {
 protected:
  ControlFleet fleet{kFleet};
  BusPair bus{fleet.service()};

  void SetUp() override { fleet.take("vcan0"), fleet.take("vcan1"); }

  std::string path_of(const std::string& spec, std::string* error = nullptr) {
    sd_bus_message* m = bus.fleet_call("GetNode");
    sd_bus_message_append(m, "s", spec.c_str());
    std::string name;
    sd_bus_message* r = bus.call(m, &name, error);
    if (!r) return "!" + name;
    const char* p = nullptr;
    sd_bus_message_read(r, "o", &p);
    std::string out = p;
    sd_bus_message_unref(r);
    return out;
  }
  // Calls a node method; returns "" on success, else the error name.
  template <typename... Args>
  std::string node_call(const std::string& node, const char* member, const char* sig, Args... args) {
    sd_bus_message* m = bus.node_call(path_of(node), member);
    if (sig && *sig) sd_bus_message_append(m, sig, args...);
    std::string name;
    sd_bus_message* r = bus.call(m, &name, &last_error);
    if (r) sd_bus_message_unref(r);
    return r ? "" : name;
  }
  std::string string_property(const std::string& node, const char* prop) {
    char* v = nullptr;
    sd_bus_error e = SD_BUS_ERROR_NULL;
    sd_bus_message* m = nullptr;
    sd_bus_message_new_method_call(bus.client(), &m, nullptr, path_of(node).c_str(), "org.freedesktop.DBus.Properties",
                                   "Get");
    sd_bus_message_append(m, "ss", control::kNodeInterface, prop);
    sd_bus_message* r = bus.call(m);
    std::string out;
    if (r && sd_bus_message_enter_container(r, 'v', "s") > 0 && sd_bus_message_read(r, "s", &v) > 0) out = v;
    if (r) sd_bus_message_unref(r);
    sd_bus_error_free(&e);
    return out;
  }
  std::vector<std::string> signal_names() {
    std::vector<std::string> out;
    for (auto& [name, m] : bus.take_signals()) {
      out.push_back(name);
      sd_bus_message_unref(m);
    }
    return out;
  }
  void subscribe() {
    sd_bus_message* r = bus.call(bus.fleet_call("Subscribe"));
    ASSERT_NE(r, nullptr);
    sd_bus_message_unref(r);
  }
  std::string last_error;
};

std::vector<CanFrame> frames_with_id(const std::vector<io::MemoryTransport::Sent>& sent, std::uint32_t id) {
  std::vector<CanFrame> out;
  for (const auto& s : sent)
    if (s.frame.id == id) out.push_back(s.frame);
  return out;
}

TEST_F(ControlServiceTest, ListNodesNamesEveryNodeWithItsPathAndState) {
  sd_bus_message* r = bus.call(bus.fleet_call("ListNodes"));
  ASSERT_NE(r, nullptr);
  ASSERT_GT(sd_bus_message_enter_container(r, 'a', "(osssysss)"), 0);
  std::vector<std::string> keys;
  const char *path, *key, *name, *iface, *profile, *personality, *state;
  std::uint8_t id;
  while (sd_bus_message_read(r, "(osssysss)", &path, &key, &name, &iface, &id, &profile, &personality, &state) > 0) {
    keys.push_back(key);
    if (std::string(key) == "vcan0/dps/0") {
      EXPECT_EQ(std::string(path), "/io/cansim/Cansimd1/node/vcan0/dps/_30");
      EXPECT_EQ(id, 0x7F);
      EXPECT_EQ(std::string(personality), "honeywell-dps");
      EXPECT_EQ(std::string(state), "pre-operational");
    }
  }
  sd_bus_message_unref(r);
  EXPECT_EQ(keys, (std::vector<std::string>{"vcan0/dps/0", "vcan0/generic/0", "vcan0/generic/1", "vcan0/generic/2",
                                            "vcan1/other/0"}));
}

TEST_F(ControlServiceTest, GetNodeResolvesKeysNamesIndicesAndNodeIds) {
  const std::string g1 = path_of("vcan0/generic/1");
  EXPECT_EQ(g1, "/io/cansim/Cansimd1/node/vcan0/generic/_31");
  EXPECT_EQ(path_of("generic/1"), g1);
  EXPECT_EQ(path_of("vcan0/0x11"), g1);
  EXPECT_EQ(path_of("vcan0/17"), g1);
  EXPECT_EQ(path_of("dps"), path_of("vcan0/0x7F"));
  std::string why;
  EXPECT_EQ(path_of("generic", &why), "!io.cansim.Error.UnknownNode");
  EXPECT_NE(why.find("names 3 nodes"), std::string::npos) << why;
  EXPECT_EQ(path_of("nope", &why), "!io.cansim.Error.UnknownNode");
  EXPECT_EQ(path_of("vcan0/0x55"), "!io.cansim.Error.UnknownNode");
}

TEST_F(ControlServiceTest, UnknownObjectPathIsUnknownObject) {
  sd_bus_message* m = bus.node_call("/io/cansim/Cansimd1/node/vcan0/nothing/0", "Nmt");
  sd_bus_message_append(m, "s", "start");
  std::string name;
  EXPECT_EQ(bus.call(m, &name), nullptr);
  EXPECT_EQ(name, "org.freedesktop.DBus.Error.UnknownObject");
}

TEST_F(ControlServiceTest, NmtStartActsAtOnceAndIsSignalled) {
  subscribe();
  fleet.run_until(500 * kMs);
  fleet.take("vcan0");
  EXPECT_EQ(node_call("vcan0/0x10", "Nmt", "s", "start"), "");
  EXPECT_EQ(string_property("vcan0/0x10", "NmtState"), "operational");
  auto names = signal_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "NmtStateChanged"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "PropertiesChanged"), names.end());
  // TPDO1 (event timer 100 ms) of node 0x10 only: the others stay pre-operational.
  fleet.run_until(800 * kMs);
  auto sent = fleet.take("vcan0");
  EXPECT_GE(frames_with_id(sent, 0x190).size(), 2u);
  EXPECT_TRUE(frames_with_id(sent, 0x191).empty());
  EXPECT_EQ(node_call("vcan0/0x10", "Nmt", "s", "jump"), "io.cansim.Error.InvalidArgument");
}

TEST_F(ControlServiceTest, PowerCycleBootsAfterTheOffTimeWithSignals) {
  subscribe();
  fleet.run_until(100 * kMs);
  fleet.take("vcan0");
  EXPECT_EQ(node_call("generic/0", "PowerCycle", "d", 0.5), "");
  EXPECT_EQ(string_property("generic/0", "NmtState"), "initialising");
  fleet.run_until(599 * kMs);
  EXPECT_TRUE(frames_with_id(fleet.take("vcan0"), 0x710).empty());
  fleet.run_until(600 * kMs);
  auto boot = frames_with_id(fleet.take("vcan0"), 0x710);
  ASSERT_EQ(boot.size(), 1u);
  EXPECT_EQ(boot[0].data[0], 0x00);
  bus.pump();
  bool saw_boot = false;
  for (auto& [name, m] : bus.take_signals()) {
    if (name == "BootUp") {
      std::int64_t t = 0;
      std::uint8_t id = 0;
      sd_bus_message_read(m, "xy", &t, &id);
      EXPECT_EQ(t, 600 * kMs);
      EXPECT_EQ(id, 0x10);
      saw_boot = true;
    }
    sd_bus_message_unref(m);
  }
  EXPECT_TRUE(saw_boot);
  EXPECT_EQ(node_call("generic/0", "PowerCycle", "d", -1.0), "io.cansim.Error.OutOfRange");
}

TEST_F(ControlServiceTest, ReadIsTypedByTheObject) {
  sd_bus_message* m = bus.node_call(path_of("generic/2"), "Read");
  sd_bus_message_append(m, "qy", 0x1018, 4);
  sd_bus_message* r = bus.call(m);
  ASSERT_NE(r, nullptr);
  std::uint32_t serial = 0;
  ASSERT_GT(sd_bus_message_enter_container(r, 'v', "u"), 0);
  sd_bus_message_read(r, "u", &serial);
  EXPECT_EQ(serial, 3u);  // serial_number_base 1 + index 2
  sd_bus_message_unref(r);

  m = bus.node_call(path_of("generic/0"), "Read");
  sd_bus_message_append(m, "qy", 0x1008, 0);
  r = bus.call(m);
  ASSERT_NE(r, nullptr);
  const char* name = nullptr;
  ASSERT_GT(sd_bus_message_enter_container(r, 'v', "s"), 0) << "0x1008 is a VISIBLE_STRING";
  sd_bus_message_read(r, "s", &name);
  EXPECT_GT(std::strlen(name), 0u);
  sd_bus_message_unref(r);

  EXPECT_EQ(node_call("generic/0", "Read", "qy", 0x5555, 0), "io.cansim.Error.UnknownObject");
  EXPECT_EQ(node_call("generic/0", "Read", "qy", 0x1018, 9), "io.cansim.Error.UnknownObject");
}

// The DCF of a running node carries its commissioning and current values,
// and loads back as a profile.
TEST_F(ControlServiceTest, GetDcfReturnsTheNodesCurrentValues) {
  ASSERT_EQ(node_call("generic/1", "Write", "qyv", 0x1017, 0, "q", 250), "");
  sd_bus_message* r = bus.call(bus.node_call(path_of("generic/1"), "GetDcf"));
  ASSERT_NE(r, nullptr);
  const char* text = nullptr;
  ASSERT_GT(sd_bus_message_read(r, "s", &text), 0);
  const std::string dcf = text;
  sd_bus_message_unref(r);
  EXPECT_NE(dcf.find("[DeviceComissioning]\nNodeID=0x11\nNodeName=generic\nBaudrate=250"), std::string::npos) << dcf;
  EXPECT_NE(dcf.find("LSS_SerialNumber=0x00000002"), std::string::npos);
  const config::Profile p = config::profile_from_eds(config::parse_eds(dcf, "generic.dcf"));
  EXPECT_EQ(p.node_id, 0x11);
  EXPECT_EQ(p.layout->find(0x1017, 0)->default_bytes, (std::vector<std::uint8_t>{250, 0}));
  EXPECT_TRUE(p.layout->find(0x1800, 1)->default_plus_node_id);
}

TEST_F(ControlServiceTest, WriteActsAsTheApplicationWithRangeChecks) {
  // 0x1017 = 200 ms: the heartbeat follows at once.
  EXPECT_EQ(node_call("generic/0", "Write", "qyv", 0x1017, 0, "u", 200u), "");
  fleet.run_until(1000 * kMs);
  auto hb = frames_with_id(fleet.take("vcan0"), 0x710);
  EXPECT_GE(hb.size(), 4u);
  // A read-only object may be written locally.
  EXPECT_EQ(node_call("generic/0", "Write", "qyv", 0x1018, 2, "x", std::int64_t(0x4242)), "");
  // Out of the type's range, wrong kind of value.
  EXPECT_EQ(node_call("generic/0", "Write", "qyv", 0x1017, 0, "x", std::int64_t(70000)), "io.cansim.Error.OutOfRange");
  EXPECT_EQ(node_call("generic/0", "Write", "qyv", 0x1017, 0, "d", 1.5), "io.cansim.Error.InvalidArgument");
  EXPECT_EQ(node_call("generic/0", "Write", "qyv", 0x1017, 0, "s", "fast"), "io.cansim.Error.InvalidArgument");
  EXPECT_EQ(node_call("generic/0", "Write", "qyv", 0x1017, 0, "s", "300"), "");
  sd_bus_message* m = bus.node_call(path_of("generic/0"), "Read");
  sd_bus_message_append(m, "qy", 0x1018, 2);
  sd_bus_message* r = bus.call(m);
  ASSERT_NE(r, nullptr);
  std::uint32_t v = 0;
  sd_bus_message_enter_container(r, 'v', "u");
  sd_bus_message_read(r, "u", &v);
  EXPECT_EQ(v, 0x4242u);
  sd_bus_message_unref(r);
}

TEST_F(ControlServiceTest, StoreKeepsAValueOverAPowerCycle) {
  EXPECT_EQ(node_call("generic/1", "Write", "qyv", 0x1017, 0, "q", std::uint16_t(300)), "");
  EXPECT_EQ(node_call("generic/1", "Store", "y", std::uint8_t(1)), "");
  EXPECT_EQ(node_call("generic/1", "Write", "qyv", 0x1017, 0, "q", std::uint16_t(700)), "");
  EXPECT_EQ(node_call("generic/1", "PowerCycle", "d", 0.0), "");
  fleet.run_until(10 * kMs);
  sd_bus_message* m = bus.node_call(path_of("generic/1"), "Read");
  sd_bus_message_append(m, "qy", 0x1017, 0);
  sd_bus_message* r = bus.call(m);
  ASSERT_NE(r, nullptr);
  std::uint16_t v = 0;
  sd_bus_message_enter_container(r, 'v', "q");
  sd_bus_message_read(r, "q", &v);
  EXPECT_EQ(v, 300u);
  sd_bus_message_unref(r);
  EXPECT_EQ(node_call("generic/1", "Store", "y", std::uint8_t(0)), "io.cansim.Error.OutOfRange");
}

TEST_F(ControlServiceTest, AMastersSdoWriteIsSignalledTyped) {
  subscribe();
  CanFrame f{};
  f.id = 0x610;
  f.dlc = 8;
  const std::uint8_t req[8] = {0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01, 0, 0};  // 0x1017 = 500
  std::memcpy(f.data, req, 8);
  fleet.run_until(5 * kMs);
  fleet.receive("vcan0", f);
  bus.pump();
  bool seen = false;
  for (auto& [name, m] : bus.take_signals()) {
    if (name == "ObjectWritten") {
      std::int64_t t;
      std::uint16_t index;
      std::uint8_t sub;
      std::uint16_t value = 0;
      const char* via = nullptr;
      sd_bus_message_read(m, "xqy", &t, &index, &sub);
      sd_bus_message_enter_container(m, 'v', "q");
      sd_bus_message_read(m, "q", &value);
      sd_bus_message_exit_container(m);
      sd_bus_message_read(m, "s", &via);
      EXPECT_EQ(t, 5 * kMs);
      EXPECT_EQ(index, 0x1017);
      EXPECT_EQ(value, 500);
      EXPECT_STREQ(via, "sdo");
      seen = true;
    }
    sd_bus_message_unref(m);
  }
  EXPECT_TRUE(seen);
}

TEST_F(ControlServiceTest, SignalsOnlyReachSubscribers) {
  fleet.run_until(5 * kMs);
  EXPECT_EQ(node_call("generic/0", "Nmt", "s", "start"), "");
  EXPECT_TRUE(signal_names().empty());
  subscribe();
  EXPECT_EQ(node_call("generic/0", "Nmt", "s", "stop"), "");
  EXPECT_FALSE(signal_names().empty());
  sd_bus_message_unref(bus.call(bus.fleet_call("Unsubscribe")));
  EXPECT_EQ(node_call("generic/0", "Nmt", "s", "preop"), "");
  EXPECT_TRUE(signal_names().empty());
}

// Fleet properties, read as a client reads them.
sd_bus_message* fleet_property(BusPair& bus, const char* name, const char* type) {
  sd_bus_message* m = nullptr;
  sd_bus_message_new_method_call(bus.client(), &m, nullptr, control::kRootPath, "org.freedesktop.DBus.Properties",
                                 "Get");
  sd_bus_message_append(m, "ss", control::kFleetInterface, name);
  sd_bus_message* r = bus.call(m);
  if (r && sd_bus_message_enter_container(r, 'v', type) <= 0) {
    sd_bus_message_unref(r);
    return nullptr;
  }
  return r;
}

std::map<std::string, std::string> bus_states(BusPair& bus) {
  std::map<std::string, std::string> out;
  sd_bus_message* r = fleet_property(bus, "BusStates", "a{ss}");
  const char *k, *v;
  if (r && sd_bus_message_enter_container(r, 'a', "{ss}") > 0)
    while (sd_bus_message_read(r, "{ss}", &k, &v) > 0) out[k] = v;
  if (r) sd_bus_message_unref(r);
  return out;
}

TEST_F(ControlServiceTest, ControllerStateIsAPropertyAndASignal) {
  using M = std::map<std::string, std::string>;
  EXPECT_EQ(bus_states(bus), (M{{"vcan0", "error-active"}, {"vcan1", "error-active"}}));
  subscribe();
  // As the daemon does with a real interface's error frame (Daemon::take_controller_reports).
  fleet.core().controller_event(fleet.bus_id("vcan1"), {CanState::kBusOff, true, false}, 5 * kMs);
  fleet.service().bus_state_changed("vcan1", CanState::kErrorPassive, CanState::kBusOff, 5 * kMs);
  bus.pump();
  bool seen = false, changed = false;
  for (auto& [name, m] : bus.take_signals()) {
    if (name == "BusStateChanged") {
      std::int64_t t = 0;
      const char *iface, *old, *now;
      ASSERT_GT(sd_bus_message_read(m, "xsss", &t, &iface, &old, &now), 0);
      EXPECT_EQ(t, 5 * kMs);
      EXPECT_EQ(std::string(iface) + " " + old + " -> " + now, "vcan1 error-passive -> bus-off");
      seen = true;
    }
    changed |= name == "PropertiesChanged";
    sd_bus_message_unref(m);
  }
  EXPECT_TRUE(seen && changed);
  EXPECT_EQ(bus_states(bus), (M{{"vcan0", "error-active"}, {"vcan1", "bus-off"}}));
  EXPECT_FALSE(fleet.core().node(fleet.node("vcan1/other/0").ref).on_bus());
}

TEST(ControlBusLoad, TimedBusFiguresAsAProperty) {
  ControlFleet fleet(R"(
interfaces: {vcan0: {bus_model: timed}, vcan1: {}}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 0x10, count: 20, name: generic}
  - {profile: generic-404, interface: vcan1, node_id: 0x10, name: other}
)");
  BusPair bus(fleet.service());
  fleet.run_until(2'500 * kMs);  // boot-ups at 0, heartbeats each second, all at once
  sd_bus_message* r = fleet_property(bus, "BusLoad", "a(ssddddxxxxxuut)");
  ASSERT_NE(r, nullptr);
  ASSERT_GT(sd_bus_message_enter_container(r, 'a', "(ssddddxxxxxuut)"), 0);
  const char *name, *model;
  double o1, o10, c1, c10;
  std::int64_t p50, p99, max, slip99, slip_max;
  std::uint32_t queued, capacity;
  std::uint64_t dropped;
  ASSERT_GT(sd_bus_message_read(r, "(ssddddxxxxxuut)", &name, &model, &o1, &o10, &c1, &c10, &p50, &p99, &max, &slip99,
                                &slip_max, &queued, &capacity, &dropped),
            0);
  EXPECT_EQ(std::string(name) + " " + model, "vcan0 timed");
  EXPECT_EQ(slip99 + slip_max, 0);  // a fake clock is never late
  // 20 heartbeats a second (0x710..0x723, 58 to 60 bits each) at 250 kbit/s
  // in the last full second (1.5 .. 2.5 s): about 0.47 %.
  int beats = 0, first19 = 0, boot_ups19 = 0;
  for (std::uint32_t i = 0; i < 20; ++i) {
    beats += io::wire_bits(F(0x710 + i, {0x7F}));
    if (i < 19) first19 += io::wire_bits(F(0x710 + i, {0x7F}));
    if (i < 19) boot_ups19 += io::wire_bits(F(0x710 + i, {0x00}));
  }
  EXPECT_NEAR(c1, beats / 250'000.0, 1e-12);
  EXPECT_EQ(o1, c1);
  // They leave one after the other, lowest CAN-ID first: the last waits for
  // the 19 before it (4 µs a bit); so did the boot-ups at 0 s, in the window too.
  EXPECT_EQ(max, std::max(first19, boot_ups19) * 4);
  EXPECT_LE(p50, first19 * 4 / 2 * 1.125);
  EXPECT_EQ(capacity, 1024u);
  EXPECT_EQ(queued + dropped, 0u);
  ASSERT_GT(sd_bus_message_read(r, "(ssddddxxxxxuut)", &name, &model, &o1, &o10, &c1, &c10, &p50, &p99, &max, &slip99,
                                &slip_max, &queued, &capacity, &dropped),
            0);
  EXPECT_EQ(std::string(name) + " " + model, "vcan1 ideal");
  EXPECT_EQ(capacity, 0u);
  sd_bus_message_unref(r);
}

TEST_F(ControlServiceTest, AddNodesBootsThemAndRefusesCollisionsAtomically) {
  subscribe();
  fleet.run_until(5 * kMs);
  sd_bus_message* m = bus.fleet_call("AddNodes");
  sd_bus_message_append(m, "s", "{profile: generic-404, interface: vcan1, node_id: 0x30, count: 2, name: extra}");
  sd_bus_message* r = bus.call(m);
  ASSERT_NE(r, nullptr);
  sd_bus_message_unref(r);
  auto sent = fleet.take("vcan1");
  EXPECT_EQ(frames_with_id(sent, 0x730).size(), 1u);
  EXPECT_EQ(frames_with_id(sent, 0x731).size(), 1u);
  auto names = signal_names();
  EXPECT_EQ(std::count(names.begin(), names.end(), "NodeAdded"), 2);
  // Node-ID 0x31 is taken: nothing of this fragment is added.
  m = bus.fleet_call("AddNodes");
  sd_bus_message_append(m, "s",
                        "[{profile: generic-404, interface: vcan1, node_id: 0x40, name: a},\n"
                        " {profile: generic-404, interface: vcan1, node_id: 0x31, name: b}]");
  std::string name, message;
  EXPECT_EQ(bus.call(m, &name, &message), nullptr);
  EXPECT_EQ(name, "io.cansim.Error.Config");
  EXPECT_NE(message.find("0x31"), std::string::npos) << message;
  EXPECT_EQ(path_of("vcan1/a/0"), "!io.cansim.Error.UnknownNode");
  // A bad key names the fragment's line.
  m = bus.fleet_call("AddNodes");
  sd_bus_message_append(m, "s", "profile: generic-404\ninterface: vcan1\nnode_idd: 3\n");
  EXPECT_EQ(bus.call(m, &name, &message), nullptr);
  EXPECT_NE(message.find(":3:"), std::string::npos) << message;
  EXPECT_NE(message.find("node_idd"), std::string::npos) << message;
}

TEST_F(ControlServiceTest, RemoveNodeSilencesIt) {
  fleet.run_until(5 * kMs);
  sd_bus_message* m = bus.fleet_call("RemoveNode");
  sd_bus_message_append(m, "s", "vcan1/0x20");
  sd_bus_message* r = bus.call(m);
  ASSERT_NE(r, nullptr);
  sd_bus_message_unref(r);
  fleet.take("vcan1");
  fleet.run_until(3000 * kMs);
  EXPECT_TRUE(frames_with_id(fleet.take("vcan1"), 0x720).empty());
  EXPECT_EQ(path_of("other"), "!io.cansim.Error.UnknownNode");
}

TEST_F(ControlServiceTest, IntrospectionListsNodesAndManagedObjects) {
  sd_bus_message* m = nullptr;
  sd_bus_message_new_method_call(bus.client(), &m, nullptr, "/io/cansim/Cansimd1/node/vcan0",
                                 "org.freedesktop.DBus.Introspectable", "Introspect");
  sd_bus_message* r = bus.call(m);
  ASSERT_NE(r, nullptr);
  const char* xml = nullptr;
  sd_bus_message_read(r, "s", &xml);
  EXPECT_NE(std::string(xml).find("node name=\"dps/_30\""), std::string::npos) << xml;
  sd_bus_message_unref(r);
  sd_bus_message_new_method_call(bus.client(), &m, nullptr, control::kRootPath, "org.freedesktop.DBus.ObjectManager",
                                 "GetManagedObjects");
  r = bus.call(m);
  ASSERT_NE(r, nullptr);
  ASSERT_GT(sd_bus_message_enter_container(r, 'a', "{oa{sa{sv}}}"), 0);
  int objects = 0;
  while (sd_bus_message_enter_container(r, 'e', "oa{sa{sv}}") > 0) {
    ++objects;
    sd_bus_message_skip(r, "oa{sa{sv}}");
    sd_bus_message_exit_container(r);
  }
  EXPECT_EQ(objects, 5);
  sd_bus_message_unref(r);
}

TEST_F(ControlServiceTest, MalformedCallsAreRefusedByName) {
  // Wrong signature: sd-bus refuses it before any handler runs.
  sd_bus_message* m = bus.node_call(path_of("generic/0"), "Read");
  sd_bus_message_append(m, "s", "0x1000");
  std::string name;
  EXPECT_EQ(bus.call(m, &name), nullptr);
  EXPECT_EQ(name, "org.freedesktop.DBus.Error.InvalidArgs");
  m = bus.node_call(path_of("generic/0"), "NoSuchMethod");
  EXPECT_EQ(bus.call(m, &name), nullptr);
  EXPECT_EQ(name, "org.freedesktop.DBus.Error.UnknownMethod");
}

// (true, reported, unit, status) of a channel property.
struct ChannelValue {
  double truth = 0, reported = 0;
  std::string unit;
  std::uint8_t status = 0;
};

class ControlPhysicsTest : public ControlServiceTest {
 protected:
  ChannelValue channel(const std::string& node, const char* prop) {
    sd_bus_message* m = nullptr;
    sd_bus_message_new_method_call(bus.client(), &m, nullptr, path_of(node).c_str(), "org.freedesktop.DBus.Properties",
                                   "Get");
    sd_bus_message_append(m, "ss", control::kNodeInterface, prop);
    sd_bus_message* r = bus.call(m);
    ChannelValue v;
    const char* unit = nullptr;
    if (r && sd_bus_message_enter_container(r, 'v', "(ddsy)") > 0 &&
        sd_bus_message_read(r, "(ddsy)", &v.truth, &v.reported, &unit, &v.status) > 0)
      v.unit = unit;
    if (r) sd_bus_message_unref(r);
    return v;
  }
  // The REAL32 PV of the last TPDO1 (0x180 + id) on vcan0.
  float last_tpdo1(std::uint32_t id) {
    auto pdos = frames_with_id(fleet.take("vcan0"), 0x180 + id);
    float v = std::nanf("");
    if (!pdos.empty()) std::memcpy(&v, pdos.back().data, 4);
    return v;
  }
};

TEST_F(ControlPhysicsTest, StepMovesTheTruthAndTheTpdosFollow) {
  fleet.run_until(10 * kMs);
  EXPECT_EQ(node_call("generic/0", "Nmt", "s", "start"), "");
  EXPECT_EQ(node_call("generic/0", "Step", "sds", "pressure", 3.0, "bar"), "");
  fleet.run_until(400 * kMs);
  ChannelValue p = channel("generic/0", "Pressure");
  EXPECT_DOUBLE_EQ(p.truth, 3.0);
  EXPECT_NEAR(p.reported, 3.0, 0.02);
  EXPECT_EQ(p.unit, "bar");
  EXPECT_NEAR(last_tpdo1(0x10), 3.0, 0.02);
  // Units convert: 100 kPa = 1 bar; psi.
  EXPECT_EQ(node_call("generic/0", "Step", "sds", "pressure", 100.0, "kPa"), "");
  EXPECT_DOUBLE_EQ(channel("generic/0", "Pressure").truth, 1.0);
  EXPECT_EQ(node_call("generic/0", "Step", "sds", "temperature", 50.0, "degC"), "");
  EXPECT_DOUBLE_EQ(channel("generic/0", "Temperature").truth, 50.0);
}

TEST_F(ControlPhysicsTest, RampReachesTheTargetAfterItsDuration) {
  fleet.run_until(10 * kMs);
  EXPECT_EQ(node_call("generic/0", "Step", "sds", "pressure", 2.0, "bar"), "");
  EXPECT_EQ(node_call("generic/0", "Ramp", "sdsd", "pressure", 6.0, "bar", 2.0), "");
  fleet.run_until(1010 * kMs);
  EXPECT_NEAR(channel("generic/0", "Pressure").truth, 4.0, 1e-6);
  fleet.run_until(3000 * kMs);
  EXPECT_NEAR(channel("generic/0", "Pressure").truth, 6.0, 1e-9);
  EXPECT_EQ(node_call("generic/0", "Ramp", "sdsd", "pressure", 6.0, "bar", -1.0), "io.cansim.Error.OutOfRange");
}

TEST_F(ControlPhysicsTest, OverrideReportsExactlyAndClears) {
  fleet.run_until(10 * kMs);
  EXPECT_EQ(node_call("generic/0", "Override", "sds", "pressure", 7.25, "bar"), "");
  fleet.run_until(20 * kMs);
  ChannelValue p = channel("generic/0", "Pressure");
  EXPECT_EQ(p.reported, 7.25);
  EXPECT_NE(p.truth, 7.25);
  EXPECT_EQ(node_call("generic/0", "ClearOverride", "s", "pressure"), "");
  EXPECT_NE(channel("generic/0", "Pressure").reported, 7.25);
}

TEST_F(ControlPhysicsTest, SetModelTakesAnyProfileModelAndRestoreModelUndoesIt) {
  fleet.run_until(10 * kMs);
  EXPECT_EQ(node_call("generic/0", "SetModel", "ss", "pressure", "- constant: 4 bar\n- constant: 0.5 bar\n"), "");
  EXPECT_DOUBLE_EQ(channel("generic/0", "Pressure").truth, 4.5);
  EXPECT_EQ(node_call("generic/0", "SetModel", "ss", "pressure", "- constant: 4 bar\n- bogus: 1\n"),
            "io.cansim.Error.InvalidArgument");
  EXPECT_NE(last_error.find("<SetModel>:2:"), std::string::npos) << last_error;
  EXPECT_EQ(node_call("generic/0", "SetModel", "ss", "pressure", "[unclosed"), "io.cansim.Error.InvalidArgument");
  EXPECT_DOUBLE_EQ(channel("generic/0", "Pressure").truth, 4.5) << "a refused model changes nothing";
  EXPECT_EQ(node_call("generic/0", "RestoreModel", "s", "pressure"), "");
  EXPECT_NE(channel("generic/0", "Pressure").truth, 4.5);
}

TEST_F(ControlPhysicsTest, BadChannelsAndUnitsAreRefusedByName) {
  EXPECT_EQ(node_call("generic/0", "Step", "sds", "flow", 1.0, "bar"), "io.cansim.Error.UnknownChannel");
  EXPECT_EQ(node_call("generic/0", "Step", "sds", "pressure", 1.0, "furlong"), "io.cansim.Error.UnknownUnit");
  EXPECT_EQ(node_call("generic/0", "Step", "sds", "pressure", 1.0, "degC"), "io.cansim.Error.UnknownUnit");
  EXPECT_EQ(node_call("generic/0", "Step", "sds", "temperature", -300.0, "degC"), "io.cansim.Error.OutOfRange");
  EXPECT_EQ(node_call("generic/0", "Step", "sds", "pressure", std::nan(""), "bar"), "io.cansim.Error.OutOfRange");
}

TEST_F(ControlPhysicsTest, ArmedFaultSendsItsEmcyIsListedAndCancels) {
  subscribe();
  fleet.run_until(10 * kMs);
  fleet.take("vcan0");
  sd_bus_message* m = bus.node_call(path_of("dps"), "ArmFault");
  sd_bus_message_append(m, "sa{ss}", "open", 1, "after", "100 ms");
  sd_bus_message* r = bus.call(m);
  ASSERT_NE(r, nullptr);
  std::uint32_t id = 0;
  sd_bus_message_read(r, "u", &id);
  sd_bus_message_unref(r);
  fleet.run_until(300 * kMs);
  auto emcy = frames_with_id(fleet.take("vcan0"), 0xFF);
  ASSERT_FALSE(emcy.empty()) << "sensor open raises an EMCY";
  bus.pump();
  std::int64_t started = -1;
  int emcy_signals = 0;
  for (auto& [name, s] : bus.take_signals()) {
    if (name == "FaultStarted") {
      std::uint32_t sid = 0;
      const char* kind = nullptr;
      sd_bus_message_read(s, "xus", &started, &sid, &kind);
      EXPECT_EQ(sid, id);
      EXPECT_STREQ(kind, "open");
    }
    emcy_signals += name == "EmcySent";
    sd_bus_message_unref(s);
  }
  EXPECT_EQ(started, 110 * kMs);
  EXPECT_GE(emcy_signals, 1);
  // The DPS (node 0x7F) reports an open sensor (manual §5.4). Listed as active; cancelled it is gone.
  r = bus.call(bus.node_call(path_of("dps"), "ListFaults"));
  ASSERT_NE(r, nullptr);
  ASSERT_GT(sd_bus_message_enter_container(r, 'a', "(ussbxxxu)"), 0);
  std::uint32_t lid = 0, count = 0;
  const char *kind = nullptr, *ch = nullptr;
  int active = 0;
  std::int64_t first = 0, duration = 0, period = 0;
  ASSERT_GT(sd_bus_message_read(r, "(ussbxxxu)", &lid, &kind, &ch, &active, &first, &duration, &period, &count), 0);
  EXPECT_EQ(lid, id);
  EXPECT_TRUE(active);
  EXPECT_EQ(first, 110 * kMs);
  EXPECT_EQ(duration, -1);
  sd_bus_message_unref(r);
  EXPECT_EQ(node_call("dps", "CancelFault", "u", id), "");
  EXPECT_EQ(node_call("dps", "CancelFault", "u", id), "io.cansim.Error.UnknownFault");
  fleet.run_until(400 * kMs);
  auto reset = frames_with_id(fleet.take("vcan0"), 0xFF);
  ASSERT_FALSE(reset.empty());
  EXPECT_EQ(reset.back().data[0], 0x00);
  EXPECT_EQ(reset.back().data[1], 0x00) << "error reset EMCY when the fault ends";
}

TEST_F(ControlPhysicsTest, FaultArgumentsAreCheckedByTheProfileParser) {
  sd_bus_message* m = bus.node_call(path_of("generic/0"), "ArmFault");
  sd_bus_message_append(m, "sa{ss}", "melt", 0);
  std::string name, message;
  EXPECT_EQ(bus.call(m, &name, &message), nullptr);
  EXPECT_EQ(name, "io.cansim.Error.UnknownFault");
  m = bus.node_call(path_of("generic/0"), "ArmFault");
  sd_bus_message_append(m, "sa{ss}", "drift", 1, "duration", "-2 s");
  EXPECT_EQ(bus.call(m, &name, &message), nullptr);
  EXPECT_EQ(name, "io.cansim.Error.InvalidArgument");
  EXPECT_NE(message.find("duration"), std::string::npos) << message;
  m = bus.node_call(path_of("generic/0"), "ArmFault");
  sd_bus_message_append(m, "sa{ss}", "drift", 1, "colour", "red");
  EXPECT_EQ(bus.call(m, &name, &message), nullptr);
  EXPECT_NE(message.find("colour"), std::string::npos) << message;
}

TEST_F(ControlPhysicsTest, CancellingAPowerCycleBootsTheNodeAtOnce) {
  fleet.run_until(10 * kMs);
  sd_bus_message* m = bus.node_call(path_of("generic/0"), "ArmFault");
  sd_bus_message_append(m, "sa{ss}", "power_cycle", 1, "duration", "10 s");
  sd_bus_message* r = bus.call(m);
  ASSERT_NE(r, nullptr);
  std::uint32_t id = 0;
  sd_bus_message_read(r, "u", &id);
  sd_bus_message_unref(r);
  fleet.run_until(500 * kMs);
  EXPECT_EQ(string_property("generic/0", "NmtState"), "initialising");
  fleet.take("vcan0");
  EXPECT_EQ(node_call("generic/0", "CancelFault", "u", id), "");
  auto boot = fleet.take("vcan0");
  ASSERT_EQ(frames_with_id(boot, 0x710).size(), 1u);
  EXPECT_EQ(frames_with_id(boot, 0x710)[0].data[0], 0x00);
}

// Fleet1.Reset: everything a bench changed is gone, every node boots again.
TEST_F(ControlPhysicsTest, ResetReturnsTheFleetToPowerOnAsConfigured) {
  fleet.run_until(10 * kMs);
  EXPECT_EQ(node_call("generic/1", "Write", "qyv", 0x1017, 0, "q", std::uint16_t(300)), "");
  EXPECT_EQ(node_call("generic/1", "Store", "y", std::uint8_t(1)), "");
  EXPECT_EQ(node_call("generic/1", "Nmt", "s", "start"), "");
  EXPECT_EQ(node_call("generic/0", "Override", "sds", "pressure", 7.25, "bar"), "");
  sd_bus_message* m = bus.node_call(path_of("dps"), "ArmFault");
  sd_bus_message_append(m, "sa{ss}", "open", 0);
  sd_bus_message* r = bus.call(m);
  ASSERT_NE(r, nullptr);
  sd_bus_message_unref(r);
  m = bus.fleet_call("AddNodes");
  sd_bus_message_append(m, "s", "{profile: generic-404, interface: vcan1, node_id: 0x30, name: extra}");
  r = bus.call(m);
  ASSERT_NE(r, nullptr);
  sd_bus_message_unref(r);
  m = bus.fleet_call("RemoveNode");
  sd_bus_message_append(m, "s", "other");
  r = bus.call(m);
  ASSERT_NE(r, nullptr);
  sd_bus_message_unref(r);
  fleet.run_until(500 * kMs);
  fleet.take("vcan0"), fleet.take("vcan1");

  r = bus.call(bus.fleet_call("Reset"));
  ASSERT_NE(r, nullptr);
  sd_bus_message_unref(r);
  auto vcan0 = fleet.take("vcan0");
  for (std::uint32_t id : {0x10u, 0x11u, 0x12u, 0x7Fu}) {
    auto boot = frames_with_id(vcan0, 0x700 + id);
    ASSERT_EQ(boot.size(), 1u) << std::hex << id;
    EXPECT_EQ(boot[0].data[0], 0x00) << "a boot-up";
  }
  EXPECT_EQ(frames_with_id(fleet.take("vcan1"), 0x720).size(), 1u) << "the removed node is back";
  EXPECT_EQ(path_of("extra"), "!io.cansim.Error.UnknownNode") << "the added node is gone";
  EXPECT_EQ(string_property("generic/1", "NmtState"), "pre-operational");
  m = bus.node_call(path_of("generic/1"), "Read");
  sd_bus_message_append(m, "qy", 0x1017, 0);
  r = bus.call(m);
  ASSERT_NE(r, nullptr);
  std::uint16_t heartbeat = 0;
  sd_bus_message_enter_container(r, 'v', "q");
  sd_bus_message_read(r, "q", &heartbeat);
  sd_bus_message_unref(r);
  EXPECT_EQ(heartbeat, 1000u) << "the stored 300 ms is erased: the profile's default";
  fleet.run_until(600 * kMs);
  EXPECT_NE(channel("generic/0", "Pressure").reported, 7.25) << "no override";
  r = bus.call(bus.node_call(path_of("dps"), "ListFaults"));
  ASSERT_NE(r, nullptr);
  ASSERT_GT(sd_bus_message_enter_container(r, 'a', "(ussbxxxu)"), 0);
  EXPECT_EQ(sd_bus_message_at_end(r, 0), 1) << "no armed fault";
  sd_bus_message_unref(r);
}

TEST_F(ControlPhysicsTest, GetAllAnswersForEveryNodeKind) {
  for (const char* node : {"generic/0", "dps", "other"}) {
    sd_bus_message* m = nullptr;
    sd_bus_message_new_method_call(bus.client(), &m, nullptr, path_of(node).c_str(), "org.freedesktop.DBus.Properties",
                                   "GetAll");
    sd_bus_message_append(m, "s", control::kNodeInterface);
    std::string name;
    sd_bus_message* r = bus.call(m, &name);
    EXPECT_NE(r, nullptr) << node << ": " << name;
    if (r) sd_bus_message_unref(r);
  }
  ChannelValue p = channel("dps", "Pressure");
  EXPECT_EQ(p.unit, "psi");
}

}  // namespace
}  // namespace cansim::test
