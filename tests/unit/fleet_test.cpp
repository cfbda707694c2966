#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "config/fleet.hpp"
#include "config/profile.hpp"
#include "daemon/daemon.hpp"
#include "personalities/sensor_application.hpp"
#include "support/captured_log.hpp"

namespace cansim::config {
namespace {

namespace fs = std::filesystem;

class FleetTest : public ::testing::Test {
 protected:
  FleetTest() {
    char tmpl[] = "/tmp/cansim-fleet-XXXXXX";
    dir = mkdtemp(tmpl);
    fs::create_directories(dir + "/profiles");
    fs::copy_file(std::string(CANSIM_SOURCE_DIR) + "/profiles/generic-404.yaml", dir + "/profiles/generic-404.yaml");
    search = default_search(dir + "/fleet.yaml", "");
  }
  ~FleetTest() override { fs::remove_all(dir); }
  FleetConfig parse(const std::string& text) { return parse_fleet(text, dir + "/fleet.yaml", search); }
  // The error message, with the temp dir replaced by "D".
  std::string error_of(const std::string& text) {
    try {
      parse(text);
    } catch (const ConfigError& e) {
      std::string m = e.what();
      for (auto p = m.find(dir); p != std::string::npos; p = m.find(dir)) m.replace(p, dir.size(), "D");
      return m;
    }
    return "no error";
  }
  std::string generic_text() const {
    std::ifstream in(dir + "/profiles/generic-404.yaml");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  // profiles/tabled.yaml: generic-404 with its pressure from profiles/p.csv.
  void write_tabled_profile() const {
    std::string text = generic_text();
    text.replace(text.find("    - constant: 5 bar\n"), 22, "    - table: {csv: p.csv, value_unit: bar}\n");
    std::ofstream(dir + "/profiles/tabled.yaml") << text;
    std::ofstream(dir + "/profiles/p.csv") << "0,5\n10,6\n";
  }
  // A daemon off the bus that reloads dir/fleet.yaml with its profile
  // store, as cansimd does.
  daemon::DaemonSettings reloading() const {
    daemon::DaemonSettings s;
    s.state_dir = dir + "/state";
    s.config_file = dir + "/fleet.yaml";
    s.bus = control::BusChoice::kNone;
    s.control_socket = "none";
    s.load = [file = s.config_file](ProfileStore* store) {
      ProfileSearch search = daemon::profile_search(file);
      search.store = store;
      return load_fleet(file, search);
    };
    return s;
  }
  std::string dir;
  ProfileSearch search;
};

const char* kIfaces = "interfaces:\n  vcan0: {bit_rate: 250}\n  vcan1: {}\n";

TEST_F(FleetTest, CountReplicatesOverConsecutiveNodeIdsWithDistinctSerialsAndKeys) {
  FleetConfig f = parse(std::string(kIfaces) +
                        "nodes:\n"
                        "  - {profile: generic-404, interface: vcan0, node_id: 0x10, count: 3, name: gen}\n"
                        "  - {profile: generic-404, interface: vcan1, serial: 77}\n");
  ASSERT_EQ(f.interfaces.size(), 2u);
  EXPECT_EQ(f.interfaces[0].bit_rate_kbit, 250u);
  EXPECT_EQ(f.interfaces[1].bit_rate_kbit, 0u);  // ask the kernel
  EXPECT_EQ(f.interfaces[0].bus_model, BusModelChoice::kAuto);
  ASSERT_EQ(f.nodes.size(), 4u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(f.nodes[i].node_id, 0x10 + i);
    EXPECT_EQ(f.nodes[i].key, "vcan0/gen/" + std::to_string(i));
    EXPECT_EQ(f.nodes[i].serial, 1u + i);  // profile serial 1, +index
    EXPECT_EQ(f.nodes[i].index, std::uint32_t(i));
    EXPECT_EQ(f.nodes[i].profile, f.nodes[0].profile);  // shared
  }
  EXPECT_NE(f.nodes[0].fingerprint, f.nodes[1].fingerprint);
  EXPECT_EQ(f.nodes[3].node_id, 0x10);  // the profile's, on another bus
  EXPECT_EQ(f.nodes[3].key, "vcan1/generic-404-16/0");
  EXPECT_EQ(f.nodes[3].serial, 77u);
  EXPECT_EQ(f.nodes[3].profile, f.nodes[0].profile);
  EXPECT_EQ(f.profiles.size(), 1u);
  EXPECT_EQ(f.seed, 1u);
}

// Without `interfaces:`, the fleet's buses are the ones its entries name, at
// the default rate; with it, an undeclared name is an error (see below).
TEST_F(FleetTest, InterfacesDefaultToTheOnesTheNodesName) {
  FleetConfig f = parse(
      "nodes: [{profile: generic-404, interface: vcan3, node_id: 0x10, count: 20, name: pt},\n"
      "        {profile: generic-404, interface: can1, name: b}]\n");
  ASSERT_EQ(f.interfaces.size(), 2u);
  EXPECT_EQ(f.interfaces[0].name, "vcan3");
  EXPECT_EQ(f.interfaces[1].name, "can1");
  EXPECT_EQ(f.interfaces[0].bit_rate_kbit, 0u);  // the kernel's, else 250
  EXPECT_EQ(f.nodes.size(), 21u);
  EXPECT_EQ(error_of("nodes: [{profile: generic-404, interface: vcan_too_long_name0}]\n"),
            "D/fleet.yaml:1:43: nodes[0].interface: expected a network interface name (at most 15 characters), "
            "got 'vcan_too_long_name0'");
}

// physics / sensor / faults of an entry lie over the profile's: a channel,
// a sensor key, the fault list; the personality's settings follow (SMC maps
// its field value over the sensor range).
TEST_F(FleetTest, PhysicsOverridesMakeAPrivateProfile) {
  const std::string smc = std::string(CANSIM_SOURCE_DIR) + "/profiles/smc.yaml";
  FleetConfig f = parse(std::string(kIfaces) +
                        "nodes:\n"
                        "  - {profile: " +
                        smc +
                        ", interface: vcan0, node_id: 1}\n"
                        "  - profile: " +
                        smc +
                        "\n"
                        "    interface: vcan0\n"
                        "    node_id: 2\n"
                        "    physics: {pressure: 4 bar}\n"
                        "    sensor: {pressure: {range: [0 bar, 10 bar]}}\n"
                        "    faults: [{kind: open, channel: pressure, at: 1 s}]\n");
  ASSERT_EQ(f.nodes.size(), 2u);
  const model::PhysicsConfig& base = f.nodes[0].profile->physics;
  const model::PhysicsConfig& mine = f.nodes[1].profile->physics;
  ASSERT_EQ(mine.process.pressure.size(), 1u);
  EXPECT_DOUBLE_EQ(std::get<physics::ConstantSpec>(mine.process.pressure[0]).value, 4.0e5);
  EXPECT_EQ(mine.process.temperature.size(), base.process.temperature.size());  // the profile's
  EXPECT_DOUBLE_EQ(mine.sensor.pressure.range_max, 10.0e5);
  EXPECT_DOUBLE_EQ(base.sensor.pressure.range_max, 5.0e5);
  EXPECT_DOUBLE_EQ(mine.sensor.pressure.noise_rms, base.sensor.pressure.noise_rms);  // the profile's other keys
  EXPECT_EQ(mine.faults.size(), 1u);
  EXPECT_DOUBLE_EQ(std::get<model::SmcSettings>(f.nodes[1].profile->device).range_max[0], 10.0e5);
}

TEST_F(FleetTest, PhysicsOverrideErrorsNameTheFleetFile) {
  try {
    parse(std::string(kIfaces) +
          "nodes:\n  - {profile: generic-404, interface: vcan0, sensor: {pressure: {sample_rate: fast}}}\n");
    ADD_FAILURE() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("fleet.yaml:"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("nodes[0].sensor.pressure.sample_rate: expected a frequency"));
  }
}

// An entry's override is reported where the entry writes it
// (fleet file, line, column, nodes[i].<section>...), never as the profile's.
TEST(FleetOverrides, AMisspeltVendorKeyNamesTheFleetFile) {
  ProfileSearch search;
  search.dirs.push_back(std::string(CANSIM_SOURCE_DIR) + "/profiles");
  try {
    parse_fleet(
        "interfaces:\n  vcan0: {bit_rate: 250}\nnodes:\n"
        "  - {profile: p92c, interface: vcan0, node_id: 5, vendor: {serial_nmber_base: 9}}\n",
        "that.yaml", search);
    ADD_FAILURE() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), ::testing::StartsWith("that.yaml:4:60: nodes[0].vendor.serial_nmber_base: unknown key "
                                                "(expected one of: cia404, serial_number_base, serial_part1,"));
  }
}

TEST_F(FleetTest, EveryOverrideSectionNamesTheFleetFileLineAndColumn) {
  struct Case {
    std::string entry;  // after "  - {profile: generic-404, interface: vcan0, " (line 5, 45 columns)
    std::string error;
  } cases[] = {
      {"options: {sdo_expedited_onl: true}}", "D/fleet.yaml:5:56: nodes[0].options.sdo_expedited_onl: unknown option"},
      {"options: {heartbeat_jitter: x}}", "D/fleet.yaml:5:56: nodes[0].options.heartbeat_jitter: unknown option"},
      {"vendor: {serial_nmber_base: 9}}", "D/fleet.yaml:5:55: nodes[0].vendor.serial_nmber_base: unknown key"},
      {"vendor: {serial_number_base: -5}}",
       "D/fleet.yaml:5:75: nodes[0].vendor.serial_number_base: expected an integer in 0..4294967295, got '-5'"},
      {"vendor: {cia404: {chanels: []}}}", "D/fleet.yaml:5:64: nodes[0].vendor.cia404.chanels: unknown key"},
      {"vendor: [1]}", "D/fleet.yaml:5:54: nodes[0].vendor: expected a mapping of vendor parameters"},
      {"physics: {pressur: 1 bar}}", "D/fleet.yaml:5:56: nodes[0].physics.pressur: unknown key"},
      {"sensor: {pressure: {nois: 1 mbar}}}", "D/fleet.yaml:5:66: nodes[0].sensor.pressure.nois: unknown key"},
      {"faults: [{kin: drift}]}", "D/fleet.yaml:5:56: nodes[0].faults[0].kin: unknown key"},
      {"faults: [{kind: drift, at: soon}]}", "D/fleet.yaml:5:73: nodes[0].faults[0].at: expected a time"},
  };
  for (const Case& c : cases)
    EXPECT_THAT(
        error_of(std::string(kIfaces) + "nodes:\n  - {profile: generic-404, interface: vcan0, " + c.entry + "\n"),
        ::testing::StartsWith(c.error))
        << c.entry;
}

TEST_F(FleetTest, OptionAndVendorOverridesMakeAPrivateProfile) {
  FleetConfig f = parse(std::string("seed: 42\n") + kIfaces +
                        "nodes:\n"
                        "  - {profile: generic-404, interface: vcan0, node_id: 1}\n"
                        "  - profile: profiles/generic-404.yaml\n"
                        "    interface: vcan0\n"
                        "    node_id: 2\n"
                        "    bit_rate: 125\n"
                        "    options: {nmt_auto_start: true}\n"
                        "    vendor: {serial_number_base: 500}\n");
  EXPECT_EQ(f.seed, 42u);
  ASSERT_EQ(f.nodes.size(), 2u);
  EXPECT_NE(f.nodes[0].profile, f.nodes[1].profile);
  EXPECT_NE(f.nodes[0].profile->layout, f.nodes[1].profile->layout);
  EXPECT_FALSE(f.nodes[0].profile->options->nmt_auto_start);
  EXPECT_TRUE(f.nodes[1].profile->options->nmt_auto_start);
  EXPECT_EQ(f.nodes[1].profile->identity.serial_base, 500u);
  EXPECT_NE(f.nodes[0].profile->identity.serial_base, 500u);
  EXPECT_EQ(f.nodes[1].bit_rate_kbit, 125u);
  EXPECT_EQ(f.nodes[0].bit_rate_kbit, 250u);
  EXPECT_EQ(f.profiles.size(), 2u);
  EXPECT_EQ(f.nodes[0].serial, 1u);    // the profile's serial_number_base
  EXPECT_EQ(f.nodes[1].serial, 500u);  // the entry's
}

TEST_F(FleetTest, ProfilesAreFoundByNameOrPath) {
  EXPECT_EQ(find_profile("generic-404", dir, search), dir + "/profiles/generic-404.yaml");
  EXPECT_EQ(find_profile("profiles/generic-404.yaml", dir, search), dir + "/profiles/generic-404.yaml");
  EXPECT_EQ(find_profile(dir + "/profiles/generic-404.yaml", "", search), dir + "/profiles/generic-404.yaml");
  EXPECT_EQ(find_profile("nope", dir, search), "");
}

TEST_F(FleetTest, BusModelPerInterface) {
  FleetConfig f = parse(
      "interfaces:\n  vcan0: {bus_model: ideal}\n  vcan1: {bit_rate: 125, bus_model: timed}\n"
      "  vcan2:\nnodes: []\n");
  ASSERT_EQ(f.interfaces.size(), 3u);
  EXPECT_EQ(f.interfaces[0].bus_model, BusModelChoice::kIdeal);
  EXPECT_EQ(f.interfaces[1].bus_model, BusModelChoice::kTimed);
  EXPECT_EQ(f.interfaces[2].bus_model, BusModelChoice::kAuto);  // timed on vcan, the controller's on can
}

TEST_F(FleetTest, SocketcandBusesListenOnLoopbackUnlessAllowedElsewhere) {
  FleetConfig f = parse(
      "interfaces:\n  bench: {transport: socketcand, listen: \"127.0.0.1:0\"}\n"
      "  six: {transport: socketcand, listen: \"[::1]:4000\", bus_model: ideal}\n"
      "  wide: {transport: socketcand, listen: \"0.0.0.0:29537\", allow_remote: true}\n"
      "  plain: {transport: socketcand}\n  vcan0: {transport: socketcan}\nnodes: []\n");
  ASSERT_EQ(f.interfaces.size(), 5u);
  EXPECT_TRUE(f.interfaces[0].socketcand());
  EXPECT_EQ(f.interfaces[0].listen_host, "127.0.0.1");
  EXPECT_EQ(f.interfaces[0].listen_port, 0);
  EXPECT_EQ(f.interfaces[1].listen_host, "::1");
  EXPECT_EQ(f.interfaces[1].listen_port, 4000);
  EXPECT_EQ(f.interfaces[1].bus_model, BusModelChoice::kIdeal);
  EXPECT_TRUE(f.interfaces[2].allow_remote);
  EXPECT_EQ(f.interfaces[3].listen_host, "127.0.0.1");
  EXPECT_EQ(f.interfaces[3].listen_port, kSocketcandDefaultPort);
  EXPECT_FALSE(f.interfaces[4].socketcand());
  const std::pair<const char*, const char*> bad[] = {
      {"  b: {transport: socketcand, listen: \"10.0.0.1:1\"}",
       "D/fleet.yaml:2:38: interfaces.b.listen: expected a loopback address (127.0.0.1, ::1): the socketcand protocol "
       "has no authentication, anyone who reaches 10.0.0.1 could send frames on this bus; add allow_remote: true to "
       "listen there, got '10.0.0.1:1'"},
      {"  b: {transport: socketcand, listen: localhost:1}",
       "D/fleet.yaml:2:38: interfaces.b.listen: expected HOST:PORT with a numeric address, e.g. 127.0.0.1:29536 or "
       "[::1]:0 (port 0: a free one), got 'localhost:1'"},
      {"  b: {transport: socketcand, listen: \"127.0.0.1:70000\"}",
       "D/fleet.yaml:2:38: interfaces.b.listen: expected HOST:PORT with a numeric address, e.g. 127.0.0.1:29536 or "
       "[::1]:0 (port 0: a free one), got '127.0.0.1:70000'"},
      {"  vcan0: {listen: \"127.0.0.1:1\"}",
       "D/fleet.yaml:2:19: interfaces.vcan0.listen: expected only with transport: socketcand, got '127.0.0.1:1'"},
      {"  b: {transport: tcp}",
       "D/fleet.yaml:2:18: interfaces.b.transport: expected socketcan (a kernel interface) or socketcand, got 'tcp'"},
  };
  for (auto [iface, error] : bad) EXPECT_EQ(error_of(std::string("interfaces:\n") + iface + "\nnodes: []\n"), error);
  std::string host;
  std::uint16_t port = 0;
  EXPECT_TRUE(parse_listen_address("127.0.0.2", host, port));
  EXPECT_EQ(port, kSocketcandDefaultPort);
  EXPECT_TRUE(parse_listen_address("[::1]", host, port));
  EXPECT_EQ(host, "::1");
  EXPECT_TRUE(parse_listen_address("::1:5", host, port));  // an IPv6 address: a port needs brackets
  EXPECT_EQ(host, "::1:5");
  EXPECT_EQ(port, kSocketcandDefaultPort);
  EXPECT_FALSE(parse_listen_address("[::1]5", host, port));
  EXPECT_FALSE(parse_listen_address("127.0.0.1:", host, port));
  EXPECT_TRUE(is_loopback_address("127.1.2.3"));
  EXPECT_TRUE(is_loopback_address("::ffff:127.0.0.1"));
  EXPECT_FALSE(is_loopback_address("::"));
  EXPECT_FALSE(is_loopback_address("localhost"));
}

TEST_F(FleetTest, ErrorsNameFileLineKeyAndExpectation) {
  struct Case {
    std::string text;
    std::string error;
  };
  const std::string n = "nodes:\n  - {profile: generic-404, interface: vcan0";
  std::vector<Case> cases = {
      {"bogus: 1\n",
       "D/fleet.yaml:1:1: bogus: unknown key (expected one of: seed, interfaces, nodes, plants), got 'bogus'"},
      {std::string(kIfaces), "D/fleet.yaml:1:1: nodes: missing required key 'nodes'"},
      {"interfaces:\n  vcan0: {bitrate: 250}\nnodes: []\n",
       "D/fleet.yaml:2:11: interfaces.vcan0.bitrate: unknown key (expected one of: bit_rate, bus_model, transport, "
       "listen, allow_remote), got 'bitrate'"},
      {"interfaces:\n  vcan0: {bit_rate: 125, bus_model: fast}\nnodes: []\n",
       "D/fleet.yaml:2:37: interfaces.vcan0.bus_model: expected timed or ideal, got 'fast'"},
      {"interfaces:\n  vcan0: {bit_rate: 300}\nnodes: []\n",
       "D/fleet.yaml:2:21: interfaces.vcan0.bit_rate: expected a CiA bit rate in kbit/s: 1000, 800, 500, 250, 125, "
       "50, 20 or 10, got '300'"},
      {std::string(kIfaces) + "nodes:\n  - {interface: vcan0}\n",
       "D/fleet.yaml:5:5: nodes[0].profile: missing required key 'profile'"},
      {std::string(kIfaces) + "nodes:\n  - {profile: nope, interface: vcan0}\n",
       "D/fleet.yaml:5:15: nodes[0].profile: expected a profile file or a profile name found in: D/profiles, "
       "/tmp/profiles, "
       "profiles, got 'nope'"},
      {std::string(kIfaces) + "nodes:\n  - {profile: generic-404, interface: vcan7}\n",
       "D/fleet.yaml:5:39: nodes[0].interface: expected an interface declared under 'interfaces:' (vcan0, vcan1), "
       "got 'vcan7'"},
      {std::string(kIfaces) + n + ", node_id: 128}\n",
       "D/fleet.yaml:5:55: nodes[0].node_id: expected a node-ID 1..127 or 255 (LSS-unconfigured), got '128'"},
      {std::string(kIfaces) + n + ", node_id: 126, count: 3}\n",
       "D/fleet.yaml:5:67: nodes[0].count: expected a count that keeps node-IDs within 1..127 (first node-ID 126), "
       "got '3'"},
      {std::string(kIfaces) + n + ", nodeid: 3}\n",
       "D/fleet.yaml:5:46: nodes[0].nodeid: unknown key (expected one of: profile, interface, node_id, count, name, "
       "serial, bit_rate, record, options, vendor, physics, sensor, faults, strict), got 'nodeid'"},
      {std::string(kIfaces) + n + ", name: 'a b'}\n",
       "D/fleet.yaml:5:52: nodes[0].name: expected a name of letters, digits, '-', '_' or '.', got 'a b'"},
      {std::string(kIfaces) + n + ", options: {no_such: 1}}\n",
       "D/fleet.yaml:5:56: nodes[0].options.no_such: unknown option (see docs/profiles.md, 'Profile options'), got "
       "'no_such'"},
      {std::string(kIfaces) + n + ", node_id: 5}\n" +
           "  - {profile: generic-404, interface: vcan0, node_id: 3, count: 3}\n",
       "D/fleet.yaml:6:5: nodes[1].node_id: node-ID 5 (0x05) is already used on vcan0 by nodes[0]; expected a free "
       "node-ID"},
      {std::string(kIfaces) + n + ", name: a}\n" +
           "  - {profile: generic-404, interface: vcan0, node_id: 9, name: a}\n",
       "D/fleet.yaml:6:5: nodes[1].name: expected a name unique on interface vcan0 ('a' is used twice)"},
      {"interfaces: [\n", "D/fleet.yaml:2:1: YAML syntax error: end of sequence flow not found"},
  };
  for (const Case& c : cases) EXPECT_EQ(error_of(c.text), c.error) << c.text;
}

TEST_F(FleetTest, SameNodeIdOnOtherBusesAndSeveralUnconfiguredNodesAreFine) {
  FleetConfig f = parse(std::string(kIfaces) +
                        "nodes:\n"
                        "  - {profile: generic-404, interface: vcan0, node_id: 5}\n"
                        "  - {profile: generic-404, interface: vcan1, node_id: 5}\n"
                        "  - {profile: generic-404, interface: vcan0, node_id: 255, count: 2, name: unconf}\n");
  EXPECT_EQ(f.nodes.size(), 4u);
}

TEST_F(FleetTest, SingleNodeFleetUsesTheProfileBitRateAndNodeId) {
  FleetConfig f = single_node_fleet(dir + "/profiles/generic-404.yaml", "can3", 0x22, search);
  ASSERT_EQ(f.nodes.size(), 1u);
  EXPECT_EQ(f.nodes[0].node_id, 0x22);
  EXPECT_EQ(f.nodes[0].interface, "can3");
  EXPECT_EQ(f.nodes[0].key, "can3/generic-404/0");
  EXPECT_EQ(f.interfaces[0].bit_rate_kbit, 250u);
  EXPECT_THROW(single_node_fleet("missing", "vcan0", {}, search), ConfigError);
}

TEST_F(FleetTest, CheckBuildsEveryNodeAndTheDemoConfigIsValid) {
  FleetConfig f =
      parse(std::string(kIfaces) + "nodes:\n  - {profile: generic-404, interface: vcan0, count: 2, name: g}\n");
  EXPECT_EQ(daemon::check_fleet(f), dir + "/fleet.yaml: ok, 2 node(s) on 2 interface(s)");
  std::string demo = std::string(CANSIM_SOURCE_DIR) + "/config/cansimd.yaml";
  FleetConfig d = load_fleet(demo, daemon::profile_search(demo));
  EXPECT_GE(d.nodes.size(), 4u);
  EXPECT_NO_THROW(daemon::check_fleet(d));
}

TEST_F(FleetTest, CheckWarnsOncePerEntryAboutNodesAtAnotherBitRateThanTheirBus) {
  FleetConfig f = parse(
      "interfaces:\n  vcan0: {bit_rate: 1000}\n  vcan1: {bit_rate: 250}\nnodes:\n"
      "  - {profile: generic-404, interface: vcan0, node_id: 0x10, count: 3, name: gen}\n"
      "  - {profile: generic-404, interface: vcan0, node_id: 0x20, bit_rate: 1000, name: fine}\n"
      "  - {profile: generic-404, interface: vcan1, node_id: 0x30, bit_rate: 125, name: slow}\n"
      "  - {profile: generic-404, interface: vcan1, node_id: 255, count: 2, bit_rate: 500, name: lss}\n");
  std::vector<std::string> warnings;
  EXPECT_EQ(daemon::check_fleet(f, &warnings), dir + "/fleet.yaml: ok, 7 node(s) on 2 interface(s)");
  ASSERT_EQ(warnings.size(), 3u);
  EXPECT_EQ(
      warnings[0],
      "vcan0/gen: 3 nodes (node-IDs 0x10..0x12) run at 250 kbit/s but vcan0 at 1000 kbit/s: they stay silent "
      "until the rates match. Fix: set `bit_rate: 1000` on the node entry (or `bit_rate: 250` on interface vcan0)");
  EXPECT_EQ(warnings[1],
            "vcan1/slow: 1 node (node-ID 0x30) runs at 125 kbit/s but vcan1 at 250 kbit/s: it stays silent until the "
            "rates match. Fix: set `bit_rate: 250` on the node entry (or `bit_rate: 125` on interface vcan1)");
  EXPECT_EQ(warnings[2].substr(0, 65), "vcan1/lss: 2 nodes (LSS-unconfigured) run at 500 kbit/s but vcan1");
  // An interface without a rate is the kernel's, else 250 kbit/s (vcan: 250).
  FleetConfig ok = parse("interfaces:\n  vcan0: {}\nnodes:\n  - {profile: generic-404, interface: vcan0}\n");
  warnings.clear();
  daemon::check_fleet(ok, &warnings);
  EXPECT_TRUE(warnings.empty());
  EXPECT_NO_THROW(daemon::check_fleet(ok));  // no warnings wanted
}

TEST_F(FleetTest, TheDaemonLogsAMismatchOncePerEntryWithTheCountAndTheFix) {
  std::ostringstream log;
  auto previous = spdlog::default_logger();
  spdlog::set_default_logger(
      std::make_shared<spdlog::logger>("test", std::make_shared<spdlog::sinks::ostream_sink_st>(log)));
  {
    daemon::DaemonSettings settings;
    settings.state_dir = dir + "/state";
    settings.config_file = dir + "/fleet.yaml";  // AddNodes takes profiles from its folder
    settings.bus = control::BusChoice::kNone;
    settings.control_socket = "none";
    daemon::Daemon d(settings);
    // A bus that does not exist: the nodes run off the bus, the warning is the same.
    d.add_nodes(
        "interfaces: {cansimfz0: {bit_rate: 1000}}\nnodes:\n"
        "  - {profile: " +
        dir +
        "/profiles/generic-404.yaml, interface: cansimfz0, node_id: 1, count: 100, name: g}\n"
        "  - {profile: " +
        dir + "/profiles/generic-404.yaml, interface: cansimfz0, node_id: 101, bit_rate: 1000}\n");
    EXPECT_EQ(d.nodes().size(), 101u);
  }
  spdlog::set_default_logger(previous);
  const std::string text = log.str();
  std::size_t warnings = 0;
  for (auto at = text.find("kbit/s but cansimfz0 at"); at != std::string::npos;
       at = text.find("kbit/s but cansimfz0 at", at + 1))
    ++warnings;
  EXPECT_EQ(warnings, 1u) << text;
  EXPECT_NE(
      text.find("cansimfz0/g: 100 nodes (node-IDs 0x01..0x64) run at 250 kbit/s but cansimfz0 at 1000 kbit/s: they "
                "stay silent until the rates match. Fix: set `bit_rate: 1000` on the node entry (or `bit_rate: 250` "
                "on interface cansimfz0)"),
      std::string::npos)
      << text;
}

// A reload parses a profile file again only when its text changed: a node of
// an unchanged file shares the running nodes' profile, one whose file was
// edited restarts with the edit, one unchanged keeps running.
TEST_F(FleetTest, AReloadParsesAProfileAgainOnlyWhenItsTextChanged) {
  const std::string generic = generic_text();
  std::ofstream(dir + "/profiles/other.yaml") << generic;
  const std::string a = "  - {profile: profiles/generic-404.yaml, interface: cansimfz1, node_id: 1, name: a}\n";
  const std::string b = "  - {profile: profiles/other.yaml, interface: cansimfz1, node_id: 2, name: b}\n";
  const std::string c = "  - {profile: profiles/generic-404.yaml, interface: cansimfz1, node_id: 3, name: c}\n";
  std::ofstream(dir + "/fleet.yaml") << "nodes:\n" << a << b;
  test::CapturedLog quiet;
  daemon::Daemon d(reloading());
  d.reload();
  const control::NodeHandle* node_a = d.find("cansimfz1/a/0");
  ASSERT_TRUE(node_a);
  const Application* app_a = node_a->app;
  ASSERT_EQ(d.find("cansimfz1/b/0")->profile, "generic-404");
  std::string edited = generic;
  edited.replace(edited.find("name: generic-404"), 17, "name: edited-404");
  std::ofstream(dir + "/profiles/other.yaml") << edited;
  std::ofstream(dir + "/fleet.yaml") << "nodes:\n" << a << b << c;
  d.reload();
  ASSERT_EQ(d.nodes().size(), 3u);
  EXPECT_EQ(d.find("cansimfz1/a/0")->app, app_a);  // unchanged: not restarted
  EXPECT_EQ(d.find("cansimfz1/b/0")->profile, "edited-404");
  EXPECT_EQ(d.find("cansimfz1/c/0")->emcy_codes, d.find("cansimfz1/a/0")->emcy_codes);  // one profile, held once
}

// The nodes of one interface (GetPdoMappings) are what the whole fleet
// holds on it, in key order, after a removal as at start.
TEST_F(FleetTest, TheNodesOnAnInterfaceAreTheFleetsNodesThere) {
  std::ofstream(dir + "/fleet.yaml")
      << "nodes:\n"
      << "  - {profile: profiles/generic-404.yaml, interface: cansimfz5, node_id: 1, name: a, count: 3}\n"
      << "  - {profile: profiles/generic-404.yaml, interface: cansimfz6, node_id: 1, name: b, count: 2}\n"
      << "  - {profile: profiles/generic-404.yaml, interface: cansimfz5, node_id: 9, name: c}\n";
  test::CapturedLog quiet;
  daemon::Daemon d(reloading());
  d.reload();
  const auto keys_on = [&](const std::string& interface) {
    std::vector<std::string> keys;
    for (const control::NodeHandle* h : d.nodes_on(interface)) keys.push_back(h->key);
    return keys;
  };
  const auto filtered = [&](const std::string& interface) {
    std::vector<std::string> keys;
    for (const control::NodeHandle* h : d.nodes())
      if (h->interface == interface) keys.push_back(h->key);
    return keys;
  };
  EXPECT_EQ(keys_on("cansimfz5"),
            (std::vector<std::string>{"cansimfz5/a/0", "cansimfz5/a/1", "cansimfz5/a/2", "cansimfz5/c/0"}));
  EXPECT_EQ(keys_on("cansimfz6"), filtered("cansimfz6"));
  d.remove_node("cansimfz5/a/1");
  EXPECT_EQ(keys_on("cansimfz5"), filtered("cansimfz5"));
  EXPECT_EQ(keys_on("cansimfz5").size(), 3u);
  EXPECT_TRUE(keys_on("cansimfz7").empty());
}

// A profile's `csv:` table is part of what defines its nodes: edited alone
// (the profile's text the same), a reload parses the profile again and
// restarts them; unchanged, nothing restarts.
TEST_F(FleetTest, AReloadRestartsTheNodesOfAProfileWhoseTableWasEdited) {
  write_tabled_profile();
  std::ofstream(dir + "/fleet.yaml")
      << "nodes:\n"
      << "  - {profile: profiles/tabled.yaml, interface: cansimfz2, node_id: 1, name: t}\n"
      << "  - {profile: profiles/tabled.yaml, interface: cansimfz2, node_id: 2, name: v,"
      << " physics: {temperature: {table: {csv: profiles/p.csv, value_unit: degC}}}}\n";
  test::CapturedLog quiet;
  daemon::Daemon d(reloading());
  d.reload();
  const Application* t = d.find("cansimfz2/t/0")->app;
  const Application* v = d.find("cansimfz2/v/0")->app;
  const auto* codes = d.find("cansimfz2/t/0")->emcy_codes;
  d.reload();
  EXPECT_EQ(d.find("cansimfz2/t/0")->app, t);  // nothing changed: nothing restarts
  EXPECT_EQ(d.find("cansimfz2/v/0")->app, v);
  std::ofstream(dir + "/profiles/p.csv") << "0,5\n10,7\n";
  d.reload();
  EXPECT_NE(d.find("cansimfz2/t/0")->app, t);             // restarted
  EXPECT_NE(d.find("cansimfz2/t/0")->emcy_codes, codes);  // on a profile parsed again
  EXPECT_NE(d.find("cansimfz2/v/0")->app, v);
}

// An entry's own table is named from the fleet file's folder, however the
// fleet file is named (a relative --config, as config/cansimd.yaml).
TEST_F(FleetTest, AnEntrysTableIsReadFromTheFleetFilesFolder) {
  fs::create_directories(dir + "/tables");
  std::ofstream(dir + "/tables/t.csv") << "0,20\n10,25\n";
  std::ofstream(dir + "/fleet.yaml") << "nodes:\n  - {profile: profiles/generic-404.yaml, interface: vcan0, "
                                     << "physics: {temperature: {table: {csv: tables/t.csv, value_unit: degC}}}}\n";
  const fs::path before = fs::current_path();
  struct Back {
    fs::path to;
    ~Back() { fs::current_path(to); }
  } back{before};
  for (const auto& [cwd, file] :
       {std::pair<std::string, std::string>{dir, "fleet.yaml"},
        {fs::path(dir).parent_path().string(), fs::path(dir).filename().string() + "/fleet.yaml"},
        {"/", dir + "/fleet.yaml"}}) {
    fs::current_path(cwd);
    EXPECT_NO_THROW(load_fleet(file, default_search(file, ""))) << cwd << " " << file;
  }
}

// cansimd --profile: its table is part of what defines the node.
TEST_F(FleetTest, ASingleNodesDigestFollowsItsTable) {
  write_tabled_profile();
  const std::string profile = dir + "/profiles/tabled.yaml";
  const Digest first = single_node_fleet(profile, "vcan0", std::nullopt, search).nodes.at(0).fingerprint;
  EXPECT_EQ(single_node_fleet(profile, "vcan0", std::nullopt, search).nodes.at(0).fingerprint, first);
  std::ofstream(dir + "/profiles/p.csv") << "0,5\n10,7\n";
  EXPECT_FALSE(single_node_fleet(profile, "vcan0", std::nullopt, search).nodes.at(0).fingerprint == first);
}

TEST_F(FleetTest, RecordFilesPerNode) {
  FleetConfig f = parse(std::string(kIfaces) +
                        "nodes:\n"
                        "  - {profile: generic-404, interface: vcan0, node_id: 5, count: 2, name: a, record: r/a.csv}\n"
                        "  - {profile: generic-404, interface: vcan0, node_id: 9, record: 'r/b-{id}.csv'}\n"
                        "  - {profile: generic-404, interface: vcan1}\n");
  ASSERT_EQ(f.nodes.size(), 4u);
  EXPECT_EQ(f.nodes[0].record_file, "r/a-5.csv");
  EXPECT_EQ(f.nodes[1].record_file, "r/a-6.csv");
  EXPECT_EQ(f.nodes[2].record_file, "r/b-9.csv");
  EXPECT_EQ(f.nodes[3].record_file, "");
  // --record DIR fills in the nodes without their own file; the fingerprint follows.
  const Digest before = f.nodes[3].fingerprint;
  apply_record_option(f, "out", false);
  EXPECT_EQ(f.nodes[0].record_file, "r/a-5.csv");
  EXPECT_EQ(f.nodes[3].record_file, "out/vcan1-generic-404-16-0.csv");
  EXPECT_NE(f.nodes[3].fingerprint, before);
  FleetConfig one = single_node_fleet("generic-404", "vcan0", {}, search);
  apply_record_option(one, "x.csv", true);
  EXPECT_EQ(one.nodes[0].record_file, "x.csv");
  EXPECT_EQ(error_of(std::string(kIfaces) + "nodes:\n  - {profile: generic-404, interface: vcan0, record: out/}\n"),
            "D/fleet.yaml:5:54: nodes[0].record: expected a CSV file name, e.g. recordings/dps-{id}.csv, got 'out/'");
}

TEST_F(FleetTest, ANodeRecordsItsReadingsAndCheckDoesNotTouchTheFile) {
  const std::string file = dir + "/rec/g.csv";
  FleetConfig f =
      parse(std::string(kIfaces) + "nodes:\n  - {profile: generic-404, interface: vcan0, record: '" + file + "'}\n");
  daemon::check_fleet(f);
  EXPECT_FALSE(fs::exists(file));
  {
    auto app = daemon::make_node_application(f.nodes[0], 1);
    auto* sensor = dynamic_cast<personalities::SensorApplication*>(app.get());
    ASSERT_NE(sensor, nullptr);
    for (int i = 0; i < 3; ++i) sensor->chain().source().sample(physics::Channel::Pressure, ms(10) * i);
    sensor->chain().source().sample(physics::Channel::Temperature, ms(20));  // same instant: no new row
  }
  std::ifstream in(file);
  std::string line;
  int lines = 0;
  while (std::getline(in, line)) ++lines;
  EXPECT_EQ(lines, 4);  // header + 3 rows
}

}  // namespace
}  // namespace cansim::config

// Profile text and fleet fragments report YAML syntax errors as fleet files do.
TEST(YamlText, SyntaxErrorsNameFileLineAndColumn) {
  const auto error_of = [](auto parse) -> std::string {
    try {
      parse();
    } catch (const cansim::config::ConfigError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(error_of([] { cansim::config::parse_profile("objects: [\n", "p.yaml"); }),
            "p.yaml:2:1: YAML syntax error: end of sequence flow not found");
  EXPECT_EQ(error_of([] { cansim::config::parse_fleet_fragment("nodes: [\n", "frag.yaml", {}, {}); }),
            "frag.yaml:2:1: YAML syntax error: end of sequence flow not found");
}
