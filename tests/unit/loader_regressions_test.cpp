// Inputs found by fuzz/profile_fuzz and fuzz/fleet_fuzz that the loaders got
// wrong: each must be rejected with a config::ConfigError that names
// file:line[:column] and the key, never crash or throw anything else.
#include <gtest/gtest.h>

#include <string>

#include "config/fleet.hpp"
#include "config/profile.hpp"
#include "daemon/daemon.hpp"
#include "personalities/registry.hpp"

namespace cansim::config {
namespace {

std::string profile_error(const std::string& text) {
  try {
    Profile p = parse_profile(text, "p.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

std::string fleet_error(const std::string& text) {
  const std::string file = std::string(CANSIM_SOURCE_DIR) + "/config/f.yaml";
  try {
    FleetConfig f = parse_fleet(text, file, daemon::profile_search(file));
    daemon::check_fleet(f);
  } catch (const ConfigError& e) {
    std::string m = e.what();
    if (m.rfind(file, 0) == 0) m.replace(0, file.size(), "f.yaml");
    return m;
  }
  return "no error";
}

// Both passed --check and then took the whole daemon down with SIGSEGV at
// power-on: the personality dereferenced objects the profile did not have.
TEST(LoaderRegressions, AnSmcProfileWithoutItsChainObjectsIsRejected) {
  EXPECT_EQ(
      profile_error("personality: adz-smc\nobjects:\n  - {index: 0x1000, type: UNSIGNED32, access: ro}\n"),
      "p.yaml:3:3: objects: a numeric object 0x6121:01 (personality adz-smc needs it for the input scaling (§5))");
}

TEST(LoaderRegressions, ADpsProfileWithoutAChannelIsRejected) {
  const std::string e = profile_error("personality: honeywell-dps\nobjects: []\n");
  EXPECT_EQ(e.rfind("p.yaml:2:10: objects: at least 1 CiA 404 channel(s)", 0), 0u) << e;
}

TEST(LoaderRegressions, AnEmptyDocumentIsRejectedAtLineOne) {
  EXPECT_EQ(profile_error(""), "p.yaml:1:1: (top level): expected a profile mapping");
  EXPECT_EQ(profile_error("# only a comment\n"), "p.yaml:1:1: (top level): expected a profile mapping");
  EXPECT_EQ(fleet_error(""), "f.yaml:1:1: (top level): expected a mapping with 'nodes:' (and 'interfaces:')");
}

// profile_fuzz: a NUL byte in a key ({index:\0000x1A00, ...} is one key in
// a flow mapping) ended what() at the NUL, before the message said what was
// wrong. A message is one line: control characters are written as \xNN.
TEST(LoaderRegressions, AKeyWithANulByteIsNamedWholeInTheMessage) {
  const std::string text(
      "objects:\n  - {index:\0"
      "0x1A00, type: UNSIGNED8}\n",
      46);
  const std::string e = profile_error(text);
  EXPECT_EQ(e.rfind("p.yaml:2:6: objects[0].index:\\x00", 0), 0u) << e;  // yaml-cpp's key: index, NUL, ...
  EXPECT_NE(e.find(": unknown key (expected one of: index, sub, "), std::string::npos) << e;
}

// fleet_fuzz: yaml-cpp reads "  seed: 7\ninterfaces: ..." as {seed: 7}; with
// neither `interfaces:` nor `nodes:` the interfaces' error had no line.
TEST(LoaderRegressions, AFleetWithoutNodesNamesTheDocument) {
  EXPECT_EQ(fleet_error("  seed: 7\ninterfaces:\n  vcan0: {}\n"), "f.yaml:1:3: nodes: missing required key 'nodes'");
  EXPECT_EQ(fleet_error("nodes: 5\n"), "f.yaml:1:8: nodes: expected a list of node entries, got '5'");
}

std::string fragment_error(const std::string& text) {
  const std::string file = std::string(CANSIM_SOURCE_DIR) + "/config/f.yaml";
  try {
    parse_fleet_fragment(text, "<AddNodes #1>", daemon::profile_search(file), FleetConfig{});
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(LoaderRegressions, AFragmentThatIsNoEntryNamesLineColumnAndTopLevel) {
  EXPECT_EQ(fragment_error(""),
            "<AddNodes #1>:1:1: (top level): expected a node entry, a list of node entries or a fleet document");
  EXPECT_EQ(
      fragment_error("\n  hello\n"),
      "<AddNodes #1>:2:3: (top level): expected a node entry, a list of node entries or a fleet document, got 'hello'");
}

std::string merge_error(const std::string& text) {
  const std::string demo = std::string(CANSIM_SOURCE_DIR) + "/config/cansimd.yaml";
  FleetConfig running = load_fleet(demo, daemon::profile_search(demo));
  try {
    FleetConfig extra = parse_fleet_fragment(text, "<AddNodes #1>", daemon::profile_search(demo), running);
    merge_fleet(running, extra);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(LoaderRegressions, AFragmentsUndeclaredInterfaceIsCheckedWhereItIsNamed) {
  EXPECT_EQ(merge_error("- {profile: generic-404, node_id: 0x30,\n   interface: 'vcan0 x'}\n"),
            "<AddNodes #1>:2:15: nodes[0].interface: expected a network interface name (at most 15 characters), got "
            "'vcan0 x'");
}

TEST(LoaderRegressions, CollisionsWithTheRunningFleetNameTheEntrysLineAndKey) {
  EXPECT_EQ(merge_error("{profile: generic-404, interface: vcan0}"),
            "<AddNodes #1>:1:1: nodes[0].node_id: node vcan0/generic-404-16/0: node-ID 16 (0x10) is already used on "
            "vcan0 by vcan0/generic/0; expected a free node-ID");
  EXPECT_EQ(
      merge_error("- {profile: dps, interface: vcan1, node_id: 0x55}\n- {profile: dps, interface: vcan0, name: dps}"),
      "<AddNodes #1>:2:3: nodes[1].name: node vcan0/dps/0 already exists; expected a new name");
}

}  // namespace
}  // namespace cansim::config
