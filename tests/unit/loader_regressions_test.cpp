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
    personalities::prepare_profile(p);
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

TEST(LoaderRegressions, AnEmptyDocumentIsRejectedAtLineOne) {
  EXPECT_EQ(profile_error(""), "p.yaml:1:1: (top level): expected a profile mapping");
  EXPECT_EQ(profile_error("# only a comment\n"), "p.yaml:1:1: (top level): expected a profile mapping");
  EXPECT_EQ(fleet_error(""), "f.yaml:1:1: (top level): expected a mapping with 'interfaces:' and 'nodes:'");
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
  EXPECT_EQ(fragment_error(""), "<AddNodes #1>:1:1: (top level): expected a node entry, a list of node entries or a fleet document");
  EXPECT_EQ(fragment_error("\n  hello\n"),
            "<AddNodes #1>:2:3: (top level): expected a node entry, a list of node entries or a fleet document, got 'hello'");
}

}  // namespace
}  // namespace cansim::config
