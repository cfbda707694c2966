#include <gtest/gtest.h>

#include "daemon/cli.hpp"

namespace cansim::daemon {
namespace {

CliResult parse(std::vector<std::string> args, const char* env = nullptr) { return parse_cli(args, env); }

TEST(Cli, SingleNodeWithDefaults) {
  CliResult r = parse({"--profile", "generic-404"});
  ASSERT_EQ(r.error, "");
  EXPECT_EQ(r.options.profile, "generic-404");
  EXPECT_EQ(r.options.interface, "vcan0");
  EXPECT_FALSE(r.options.node_id);
  EXPECT_EQ(r.options.state_dir, "state");
  EXPECT_EQ(r.options.log_level, "info");
}

TEST(Cli, FleetWithEveryOptionInBothSpellings) {
  CliResult r = parse(
      {"--config=f.yaml", "--check", "--state-dir", "/s", "--log-level=debug", "--seed", "0x10", "--record", "rec"});
  ASSERT_EQ(r.error, "");
  EXPECT_EQ(r.options.record, "rec");
  EXPECT_EQ(r.options.config, "f.yaml");
  EXPECT_TRUE(r.options.check);
  EXPECT_EQ(r.options.state_dir, "/s");
  EXPECT_EQ(r.options.log_level, "debug");
  EXPECT_EQ(r.options.seed, 16u);
}

TEST(Cli, MaxClientsIsBounded) {
  EXPECT_EQ(parse({"--config", "f.yaml"}).options.max_clients, 64u);
  CliResult r = parse({"--config", "f.yaml", "--max-clients", "4096"});
  ASSERT_EQ(r.error, "");
  EXPECT_EQ(r.options.max_clients, 4096u);
  EXPECT_EQ(parse({"--config", "f.yaml", "--max-clients=1"}).options.max_clients, 1u);
  EXPECT_EQ(parse({"--config", "f.yaml", "--max-clients", "0"}).error, "--max-clients: expected 1..4096, got '0'");
  EXPECT_EQ(parse({"--config", "f.yaml", "--max-clients", "4097"}).error,
            "--max-clients: expected 1..4096, got '4097'");
  EXPECT_NE(usage_text().find("--max-clients N"), std::string::npos);
}

TEST(Cli, StrictAndQuirks) {
  CliResult r = parse({"--config", "f.yaml", "--strict"});
  EXPECT_EQ(r.error, "");
  EXPECT_TRUE(r.options.strict);
  r = parse({"--profile", "dps", "--quirks"});
  EXPECT_EQ(r.error, "");
  EXPECT_TRUE(r.options.quirks);
  EXPECT_EQ(parse({"--config", "f.yaml", "--quirks"}).error, "--quirks goes with --profile");
  EXPECT_EQ(parse({"--profile", "dps", "--strict=yes"}).error, "option --strict takes no value");
}

TEST(Cli, SocketcandServesEveryInterfaceWithoutTheKernel) {
  EXPECT_FALSE(parse({"--config", "f.yaml"}).options.socketcand);
  CliResult r = parse({"--config", "f.yaml", "--socketcand"});
  ASSERT_EQ(r.error, "");
  EXPECT_TRUE(r.options.socketcand);
  EXPECT_TRUE(parse({"--profile", "dps", "--interface", "bench", "--socketcand"}).options.socketcand);
  EXPECT_EQ(parse({"--config", "f.yaml", "--socketcand=1"}).error, "option --socketcand takes no value");
  EXPECT_NE(usage_text().find("--socketcand"), std::string::npos);
}

TEST(Cli, NodeIdAcceptsHexAndUnconfigured) {
  EXPECT_EQ(parse({"--profile", "p", "--node-id", "0x7F", "--interface", "can1"}).options.node_id, 127);
  EXPECT_EQ(parse({"--profile", "p", "--node-id", "255"}).options.node_id, 255);
}

TEST(Cli, ExportEdsWithNodeIdAndOutput) {
  CliResult r = parse({"--export-eds", "p92c", "--node-id", "5", "--output=p92c.dcf"});
  EXPECT_EQ(r.error, "");
  EXPECT_EQ(r.options.export_eds, "p92c");
  EXPECT_EQ(r.options.node_id, 5);
  EXPECT_EQ(r.options.output, "p92c.dcf");
  EXPECT_EQ(parse({"--profile", "x", "--output", "f"}).error, "--output goes with --export-eds or --export-dbc");
  EXPECT_EQ(parse({"--export-eds", "x", "--config", "f.yaml"}).error,
            "--export-eds takes a profile of its own (no --profile, --config, --interface or --check)");
}

TEST(Cli, ExportDbcOfAFleetBusOrAProfile) {
  CliResult r = parse({"--export-dbc", "config/cansimd.yaml", "--interface", "vcan1", "--output", "bus.dbc"});
  EXPECT_EQ(r.error, "");
  EXPECT_EQ(r.options.export_dbc, "config/cansimd.yaml");
  EXPECT_EQ(r.options.interface, "vcan1");
  EXPECT_TRUE(r.options.interface_given);
  EXPECT_EQ(r.options.output, "bus.dbc");
  EXPECT_EQ(parse({"--export-dbc", "dps", "--node-id", "9", "--strict"}).options.node_id, 9);
  EXPECT_FALSE(parse({"--export-dbc", "dps"}).options.interface_given);
  EXPECT_EQ(parse({"--export-dbc", "x", "--config", "f.yaml"}).error,
            "--export-dbc takes a fleet configuration or a profile of its own (no --profile, --config, --export-eds "
            "or --check)");
}

TEST(Cli, StateDirectoryFromSystemd) {
  EXPECT_EQ(parse({"--profile", "p"}, "/var/lib/cansimd").options.state_dir, "/var/lib/cansimd");
  EXPECT_EQ(parse({"--profile", "p"}, "/var/lib/a:/var/lib/b").options.state_dir, "/var/lib/a");
  EXPECT_EQ(parse({"--profile", "p", "--state-dir", "x"}, "/var/lib/a").options.state_dir, "x");
}

TEST(Cli, HelpAndVersionNeedNothingElse) {
  EXPECT_TRUE(parse({"--help"}).options.help);
  EXPECT_EQ(parse({"--help"}).error, "");
  EXPECT_TRUE(parse({"--version"}).options.version);
  EXPECT_NE(usage_text().find("--config FILE"), std::string::npos);
}

TEST(Cli, UsageErrors) {
  struct Case {
    std::vector<std::string> args;
    std::string error;
  };
  std::vector<Case> cases = {
      {{}, "expected --profile or --config"},
      {{"--profile", "p", "--config", "c"}, "--profile and --config exclude each other"},
      {{"--config", "c", "--node-id", "5"},
       "--interface and --node-id go with --profile (a --config file names its own)"},
      {{"--config", "c", "--interface", "vcan1"},
       "--interface and --node-id go with --profile (a --config file names its own)"},
      {{"--profile"}, "option --profile needs a value"},
      {{"--profile", "p", "--node-id", "0"}, "--node-id: expected 1..127 or 255, got '0'"},
      {{"--profile", "p", "--node-id", "128"}, "--node-id: expected 1..127 or 255, got '128'"},
      {{"--profile", "p", "--node-id", "x"}, "--node-id: expected 1..127 or 255, got 'x'"},
      {{"--profile", "p", "--log-level", "loud"},
       "--log-level: expected trace, debug, info, warn, error, critical or off, got 'loud'"},
      {{"--profile", "p", "--seed", "-1"}, "--seed: expected a non-negative integer, got '-1'"},
      {{"--profile", "p", "--interface", "a-very-long-interface"},
       "--interface: expected an interface name of 1..15 characters"},
      {{"--profile", "p", "--bogus"}, "unknown option --bogus"},
      {{"--profile", "p", "extra"}, "unexpected argument 'extra'"},
      {{"--check=yes", "--profile", "p"}, "option --check takes no value"},
  };
  for (const Case& c : cases) {
    std::string joined;
    for (auto& a : c.args) joined += a + " ";
    EXPECT_EQ(parse(c.args).error, c.error) << joined;
  }
}

}  // namespace
}  // namespace cansim::daemon
