// The bounds of config/limits.hpp (docs/limits.md): what a client sends is
// refused with io.cansim.Error.TooLarge before it is parsed; files a client
// names are read without blocking and never echoed; profiles for AddNodes
// come from the profile folders only; the endpoints bound clients, their
// handshake and what they leave unread; removed nodes give their memory back.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <malloc.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <fstream>
#include <sstream>

#include "config/fleet.hpp"
#include "config/limits.hpp"
#include "config/physics_config.hpp"
#include "control/endpoints.hpp"
#include "daemon/daemon.hpp"
#include "support/captured_log.hpp"
#include "support/control_fleet.hpp"
#include "support/sanitizer.hpp"

namespace cansim {
namespace {

namespace fs = std::filesystem;

constexpr const char* kTooLarge = "io.cansim.Error.TooLarge";

struct TempDir {
  std::string path;
  TempDir() {
    char tmpl[] = "/tmp/cansim-limits-XXXXXX";
    path = mkdtemp(tmpl);
  }
  ~TempDir() { fs::remove_all(path); }
};

using test::CapturedLog;

std::string repeat(const std::string& piece, std::size_t times) {
  std::string out;
  for (std::size_t i = 0; i < times; ++i) out += piece;
  return out;
}

// ---------------------------------------------------------------- the YAML pre-scan

TEST(YamlDepth, CountsBlockLevelsAndBrackets) {
  using config::yaml_depth;
  EXPECT_EQ(yaml_depth("a: 1\nb: 2\n", 99), 2);  // a mapping, its scalar values
  EXPECT_EQ(yaml_depth("a:\n  b:\n    c: 1\n", 99), 4);
  EXPECT_EQ(yaml_depth("[[[1]]]", 99), 4);
  EXPECT_EQ(yaml_depth("a: {b: [c, {d: e}]}", 99), 5);
  EXPECT_EQ(yaml_depth("- - - - x\n", 99), 5);  // compact entries nest on one line
  EXPECT_EQ(yaml_depth(repeat("- ", 40) + "x", 99), 41);
  EXPECT_EQ(yaml_depth(std::string(4000, '['), 32), 33);  // stops counting above the bound
}

TEST(YamlDepth, QuotesCommentsAndBlockScalarsAreText) {
  using config::yaml_depth;
  EXPECT_EQ(yaml_depth("a: '[[[['\nb: \"{{{\\\"{{\"\n", 99), 2);
  EXPECT_EQ(yaml_depth("a: 1  # [[[[[[\n# {{{{{{{\n", 99), 2);
  EXPECT_EQ(yaml_depth("a: |\n  [[[[[[[[\n  {{{{{{{\nb: x\n", 99), 2);
  EXPECT_EQ(yaml_depth("name: it's [1]\n", 99), 2);  // a plain scalar keeps its brackets
  EXPECT_EQ(yaml_depth("a: [it's, [x]]\n", 99), 4);  // a quote inside a plain scalar opens nothing
}

TEST(YamlDepth, CountsAliases) {
  std::size_t aliases = 0;
  EXPECT_EQ(config::yaml_depth("a: &x [1, 2]\nb: [*x,*x, {c: *x}]\nd: *x\n", 99, &aliases), 4);
  EXPECT_EQ(aliases, 4u);
  EXPECT_EQ(config::yaml_depth("a: '*x'\nb: 2*3\n", 99, &aliases), 2);
  EXPECT_EQ(aliases, 0u);
}

// Each alias is its anchored node parsed again: 2,253 of them made a 16 KiB
// SetModel take 865 ms; more than the bound are refused before parsing.
TEST(YamlSize, AliasesAreBounded) {
  std::string text = "- &t {table: {points: [[0 s, 1 bar], [1 s, 2 bar]]}}\n";
  for (std::size_t i = 0; i < limits::kYamlAliases; ++i) text += "- *t\n";
  EXPECT_NO_THROW(config::check_yaml_size(text, "<t>", limits::kYamlTextBytes));
  text += "- *t\n";
  try {
    config::check_yaml_size(text, "<t>", limits::kYamlTextBytes);
    FAIL() << "no error";
  } catch (const config::TooLarge& e) {
    EXPECT_EQ(std::string(e.what()), "<t>:18:3: (top level): 17 YAML aliases (*name); expected at most 16");
  }
}

// Everything shipped nests far below the bound.
TEST(YamlDepth, ShippedProfilesAndConfigsAreWithinTheBound) {
  for (const char* folder : {"profiles", "config"})
    for (const auto& e : fs::directory_iterator(std::string(CANSIM_SOURCE_DIR) + "/" + folder)) {
      if (e.path().extension() != ".yaml") continue;
      std::ifstream in(e.path());
      std::stringstream text;
      text << in.rdbuf();
      EXPECT_LE(config::yaml_depth(text.str(), 99), limits::kYamlDepth / 2) << e.path();
    }
}

TEST(YamlSize, BytesAndDepthAreCheckedBeforeParsing) {
  EXPECT_NO_THROW(config::check_yaml_size("a: 1", "<t>", 10));
  EXPECT_THROW(config::check_yaml_size("a: 12345678", "<t>", 10), config::TooLarge);
  try {
    config::load_yaml_text(std::string(4 << 20, '['), "<t>");  // 3.7 GB of yaml-cpp tokens, before
    FAIL() << "no error";
  } catch (const config::TooLarge& e) {
    EXPECT_EQ(std::string(e.what()), "<t>:1:32: (top level): YAML nested more than 32 levels deep");
  }
}

// ---------------------------------------------------------------- files

TEST(RegularFile, FifosDevicesAndLargeFilesAreNotRead) {
  TempDir dir;
  const std::string fifo = dir.path + "/fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  ::alarm(10);  // opening the FIFO waited for a writer, before
  EXPECT_THROW(config::read_regular_file(fifo, 100), config::ConfigError);
  ::alarm(0);
  try {
    config::read_regular_file("/dev/zero", 100);
    FAIL() << "no error";
  } catch (const config::ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "/dev/zero: not a regular file");
  }
  std::ofstream(dir.path + "/big") << std::string(101, 'x');
  EXPECT_THROW(config::read_regular_file(dir.path + "/big", 100), config::TooLarge);
  EXPECT_EQ(config::read_regular_file(dir.path + "/big", 101), std::string(101, 'x'));
}

// A profile named by a client: only from the allowed folders; one that does not
// load is named by its path, never by its bytes.
TEST(ConfinedProfiles, OutsideIsRefusedAndInsideNeverEchoed) {
  TempDir dir;
  fs::create_directories(dir.path + "/profiles");
  fs::copy_file(std::string(CANSIM_SOURCE_DIR) + "/profiles/generic-404.yaml", dir.path + "/profiles/generic-404.yaml");
  std::ofstream(dir.path + "/profiles/secret.yaml") << "line1 SECRET-A line2 SECRET-B\n";
  TempDir outside;
  std::ofstream(outside.path + "/p.yaml") << "SECRET-C\n";
  config::ProfileSearch search;
  search.dirs = {dir.path + "/profiles"};
  search.confined_to = search.dirs;
  auto error_of = [&](const std::string& ref) {
    try {
      config::parse_fleet_fragment("{profile: " + ref + ", interface: vcan0, node_id: 9}", "<AddNodes #1>", search,
                                   config::FleetConfig{});
    } catch (const config::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error_of("generic-404"), "no error");
  EXPECT_EQ(error_of(dir.path + "/profiles/generic-404.yaml"), "no error");
  const std::string out = error_of(outside.path + "/p.yaml");
  EXPECT_NE(out.find("expected a profile name or a file in the profile folders (" + dir.path + "/profiles)"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("SECRET"), std::string::npos) << out;
  // A link in the folder to a file outside is outside.
  fs::create_symlink(outside.path + "/p.yaml", dir.path + "/profiles/link.yaml");
  EXPECT_NE(error_of(dir.path + "/profiles/link.yaml").find("in the profile folders"), std::string::npos);
  const std::string in = error_of("secret");
  EXPECT_EQ(in, dir.path + "/profiles/secret.yaml: not a valid profile (`cansimd --check --profile " + dir.path +
                    "/profiles/secret.yaml` says why)");
  EXPECT_EQ(error_of("/etc/shadow").find("SECRET"), std::string::npos);
}

// A profile the fleet file loaded (not confined) whose table lies outside
// the profile folders is not handed to an AddNodes caller by the store: it
// is refused as a confined parse refuses it.
TEST(ConfinedProfiles, AStoredProfileWithATableOutsideIsRefusedToo) {
  TempDir dir, outside;
  fs::create_directories(dir.path + "/profiles");
  std::ofstream(outside.path + "/t.csv") << "0,5\n10,6\n";
  std::string text;
  {
    std::ifstream in(std::string(CANSIM_SOURCE_DIR) + "/profiles/generic-404.yaml");
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  text.replace(text.find("    - constant: 5 bar\n"), 22,
               "    - table: {csv: " + outside.path + "/t.csv, value_unit: bar}\n");
  std::ofstream(dir.path + "/profiles/tabled.yaml") << text;
  config::ProfileStore store;
  config::ProfileSearch open;
  open.dirs = {dir.path + "/profiles"};
  open.store = &store;
  const config::FleetConfig running =  // holds the profile: the store keeps it while it is used
      config::parse_fleet("nodes:\n  - {profile: tabled, interface: vcan0}\n", dir.path + "/fleet.yaml", open);
  ASSERT_EQ(running.nodes.size(), 1u);
  config::ProfileSearch confined = open;
  confined.confined_to = open.dirs;
  for (config::ProfileStore* with : {&store, static_cast<config::ProfileStore*>(nullptr)}) {
    confined.store = with;
    EXPECT_THROW(config::parse_fleet_fragment("{profile: tabled, interface: vcan0, node_id: 9}", "<AddNodes #1>",
                                              confined, config::FleetConfig{}),
                 config::ConfigError)
        << (with ? "from the store" : "parsed");
  }
}

// The running daemon allows the profile search folders, the fleet file's
// folder and the folders its profiles came from.
TEST(ConfinedProfiles, TheDaemonAllowsTheFleetsFolders) {
  TempDir dir, profiles;
  fs::copy_file(std::string(CANSIM_SOURCE_DIR) + "/profiles/generic-404.yaml", profiles.path + "/mine.yaml");
  std::ofstream(dir.path + "/fleet.yaml") << "interfaces: {cansimlt0: {}}\nnodes:\n"
                                          << "  - {profile: " << profiles.path << "/mine.yaml, interface: cansimlt0}\n";
  std::ofstream(dir.path + "/secret.txt") << "SECRET\n";
  daemon::DaemonSettings settings;
  settings.state_dir = dir.path + "/state";
  settings.config_file = dir.path + "/fleet.yaml";
  settings.load = [&](config::ProfileStore*) {
    return config::load_fleet(settings.config_file, daemon::profile_search(settings.config_file));
  };
  daemon::Daemon d(settings);
  CapturedLog quiet;
  d.reload();
  EXPECT_EQ(d.add_nodes("{profile: " + profiles.path + "/mine.yaml, interface: cansimlt0, node_id: 9, name: b}").size(),
            1u);
  try {
    d.add_nodes("{profile: " + dir.path + "/secret.txt, interface: cansimlt0, node_id: 10}");
    FAIL() << "no error";
  } catch (const config::ConfigError& e) {
    EXPECT_EQ(std::string(e.what()).find("SECRET"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a valid profile"), std::string::npos) << e.what();
  }
  EXPECT_THROW(d.add_nodes("{profile: /etc/passwd, interface: cansimlt0, node_id: 10}"), config::ConfigError);
}

// Vendor overrides are merged in one pass (a yaml-cpp lookup per key made
// 50,000 keys take 37 s): the profile's keys stay, given ones replace or add,
// the last of a repeated key wins.
TEST(VendorMerge, KeysReplaceAddAndTheLastRepeatWins) {
  config::ProfileSearch search;
  search.dirs = {std::string(CANSIM_SOURCE_DIR) + "/profiles"};
  config::FleetConfig f = config::parse_fleet(
      "interfaces: {vcan0: {}}\nnodes:\n"
      "  - {profile: dps, interface: vcan0, vendor: {span_check_period: 2 ms, span_check_period: 3 ms, "
      "serial_number_base: 5}}\n",
      "<t>", search);
  ASSERT_EQ(f.nodes.size(), 1u);
  const auto& dps = std::get<model::DpsSettings>(f.nodes[0].profile->device);
  EXPECT_EQ(dps.span_check_period_us, 3000);
  EXPECT_TRUE(dps.autozero_shifts_span);  // the profile's, kept
  EXPECT_EQ(f.nodes[0].profile->identity.serial_base, 5u);
}

TEST(AddNodesBounds, EntriesNodesAndFleetSize) {
  config::ProfileSearch search;
  search.dirs = {std::string(CANSIM_SOURCE_DIR) + "/profiles"};
  std::string entries;
  for (std::size_t i = 0; i <= limits::kAddNodesEntries; ++i)
    entries += "- {profile: generic-404, interface: vb" + std::to_string(i) + ", node_id: 1}\n";
  try {
    config::parse_fleet_fragment(entries, "<A>", search, {});
    FAIL() << "no error";
  } catch (const config::TooLarge& e) {  // the place of the list, as every other error of a fragment
    EXPECT_EQ(std::string(e.what()), "<A>:1:1: nodes: 5 node entries; expected at most 4 in one call");
  }
  const std::string two_groups =
      "- {profile: generic-404, interface: va, node_id: 1, count: 100, name: a}\n"
      "- {profile: generic-404, interface: vb, node_id: 1, count: 100, name: b}\n";
  EXPECT_THROW(config::parse_fleet_fragment(two_groups, "<A>", search, {}), config::TooLarge);
  config::FleetConfig running;
  running.nodes.resize(limits::kFleetNodes - 1);
  EXPECT_NO_THROW(
      config::parse_fleet_fragment("{profile: generic-404, interface: va, node_id: 1}", "<A>", search, running));
  EXPECT_THROW(config::parse_fleet_fragment("{profile: generic-404, interface: va, node_id: 1, count: 2}", "<A>",
                                            search, running),
               config::TooLarge);
}

TEST(Times, AreBoundedSoMicrosecondsNeverWrap) {
  EXPECT_THROW(config::parse_fault_text("<ArmFault>", "open", {{"at", "1e20 s"}}), config::ConfigError);
  EXPECT_THROW(config::parse_fault_text("<ArmFault>", "slow_sdo", {{"sdo_delay", "1e20 s"}}), config::ConfigError);
  EXPECT_EQ(config::parse_fault_text("<ArmFault>", "open", {{"at", "1e9 s"}}).timing.at_us, TimeUs(1e15));
}

// ---------------------------------------------------------------- the control API

constexpr const char* kFleet = R"(
interfaces: {vcan0: {bit_rate: 250}}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 0x10, name: g}
)";

class ControlLimits : public ::testing::Test {
 protected:
  test::ControlFleet fleet{kFleet};
  test::BusPair bus{fleet.service()};
  std::string node = control::node_path(fleet.node("vcan0/g/0"));
  std::string error_name, error;

  // Calls and returns "" on success, else the error name (message in `error`).
  template <typename Append>
  std::string call(sd_bus_message* m, Append&& append) {
    append(m);
    error_name.clear();
    sd_bus_message* r = bus.call(m, &error_name, &error);
    if (r) sd_bus_message_unref(r);
    return r ? "" : error_name;
  }
  std::string add_nodes(const std::string& yaml) {
    return call(bus.fleet_call("AddNodes"), [&](sd_bus_message* m) { sd_bus_message_append(m, "s", yaml.c_str()); });
  }
  std::string set_model(const std::string& yaml) {
    return call(bus.node_call(node, "SetModel"),
                [&](sd_bus_message* m) { sd_bus_message_append(m, "ss", "pressure", yaml.c_str()); });
  }
  std::string arm_fault(const char* kind, const std::vector<std::pair<std::string, std::string>>& params) {
    return call(bus.node_call(node, "ArmFault"), [&](sd_bus_message* m) {
      sd_bus_message_append(m, "s", kind);
      sd_bus_message_open_container(m, 'a', "{ss}");
      for (const auto& [k, v] : params) sd_bus_message_append(m, "{ss}", k.c_str(), v.c_str());
      sd_bus_message_close_container(m);
    });
  }
};

TEST_F(ControlLimits, AddNodesTextOverTheBoundsIsTooLarge) {
  const std::string entry = "{profile: generic-404, interface: vcan0, node_id: 0x20, name: x}";
  const std::string padded = entry + "\n#" + std::string(limits::kYamlTextBytes - entry.size() - 2, ' ');
  EXPECT_EQ(add_nodes(padded), "");  // exactly at the bound
  EXPECT_EQ(add_nodes(padded + " "), kTooLarge);
  EXPECT_EQ(error, "<AddNodes>: 16385 bytes of YAML; expected at most 16384");
  EXPECT_EQ(add_nodes("{profile: generic-404, interface: vcan0, node_id: 0x21, vendor: {x: " + std::string(4000, '[')),
            kTooLarge);
  EXPECT_EQ(add_nodes(repeat("- ", 200)), kTooLarge);
  EXPECT_EQ(fleet.nodes().size(), 2u);
}

TEST_F(ControlLimits, SetModelTextOverTheBoundsIsTooLarge) {
  EXPECT_EQ(set_model(std::string(limits::kYamlTextBytes + 1, ' ')), kTooLarge);
  EXPECT_EQ(set_model("- &t {table: {points: [[0 s, 1 bar]]}}\n" + repeat("- *t\n", 100)), kTooLarge);
  EXPECT_EQ(set_model(std::string(40, '[') + std::string(40, ']')), kTooLarge);
  EXPECT_EQ(set_model("5 bar"), "");
}

TEST_F(ControlLimits, ArmFaultParametersOverTheBoundsAreTooLarge) {
  std::vector<std::pair<std::string, std::string>> params(limits::kFaultParams, {"duration", "1 s"});
  EXPECT_EQ(arm_fault("drift", params), "");
  params.emplace_back("duration", "1 s");
  EXPECT_EQ(arm_fault("drift", params), kTooLarge);
  EXPECT_EQ(arm_fault("stuck", {{"value", std::string(limits::kFaultValueBytes + 1, '1')}}), kTooLarge);
  EXPECT_EQ(arm_fault("stuck", {{"value", std::string(100, '[')}}), kTooLarge);
  // Unknown keys are refused at the first one, before anything is parsed.
  EXPECT_EQ(arm_fault("open", {{"k0", "1"}, {"k1", "1"}}), "io.cansim.Error.InvalidArgument");
  EXPECT_NE(error.find("k0: unknown key"), std::string::npos) << error;
  EXPECT_EQ(arm_fault("open", {{"at", "1e20 s"}}), "io.cansim.Error.InvalidArgument");
  EXPECT_NE(error.find("at most 1e9 s"), std::string::npos) << error;
}

TEST_F(ControlLimits, ValuesThatAreNotFiniteInSiAreOutOfRange) {
  for (const char* method : {"Step", "Override"}) {
    EXPECT_EQ(call(bus.node_call(node, method),
                   [](sd_bus_message* m) { sd_bus_message_append(m, "sds", "pressure", 1e308, "bar"); }),
              "io.cansim.Error.OutOfRange")
        << method;
    EXPECT_EQ(call(bus.node_call(node, method),
                   [](sd_bus_message* m) { sd_bus_message_append(m, "sds", "temperature", 1e308, "degF"); }),
              "io.cansim.Error.OutOfRange")
        << method;
  }
}

TEST_F(ControlLimits, ErrorMessagesQuoteAtMostTheBound) {
  const std::string name(100'000, 'n');
  EXPECT_EQ(call(bus.fleet_call("GetNode"), [&](sd_bus_message* m) { sd_bus_message_append(m, "s", name.c_str()); }),
            "io.cansim.Error.UnknownNode");
  EXPECT_EQ(error.size(), limits::kErrorMessageBytes + 3);
  EXPECT_EQ(error.substr(error.size() - 3), "...");
}

TEST_F(ControlLimits, RecordingRefusesAFifo) {
  TempDir dir;
  const std::string fifo = dir.path + "/fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  ::alarm(10);
  EXPECT_EQ(call(bus.node_call(node, "StartRecording"),
                 [&](sd_bus_message* m) { sd_bus_message_append(m, "s", fifo.c_str()); }),
            "io.cansim.Error.Refused");
  ::alarm(0);
  EXPECT_EQ(error, fifo + ": not a regular file");
}

TEST_F(ControlLimits, ATableFromAFifoIsRefused) {
  TempDir dir;
  fleet.allow_folder(dir.path);
  const std::string fifo = dir.path + "/t.csv";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  ::alarm(10);
  EXPECT_EQ(set_model("table: {csv: " + fifo + "}"), "io.cansim.Error.InvalidArgument");
  ::alarm(0);
  EXPECT_NE(error.find("not a regular file"), std::string::npos) << error;
}

// A table a client names comes from the profile folders, as its profiles do:
// a file elsewhere is refused unopened, by the same words whether it exists
// or not, and its size is never told (a 0600 file of root's was readable
// through the process value; an error gave a file's exact size).
TEST_F(ControlLimits, ATableOutsideTheProfileFoldersIsRefusedUnopened) {
  TempDir dir;
  const std::string big = dir.path + "/big.csv";
  std::ofstream(big) << std::string(limits::kTableFileBytes + 1, '1');
  const std::string secret = dir.path + "/secret.csv";
  std::ofstream(secret) << "0,1\n1,2\n";
  ::chmod(secret.c_str(), 0600);
  std::string refusal;
  for (const std::string& file : {big, secret, dir.path + "/missing.csv", std::string("/etc/shadow")}) {
    EXPECT_EQ(set_model("table: {csv: " + file + "}"), "io.cansim.Error.InvalidArgument") << file;
    EXPECT_NE(error.find("cannot load table: expected a file in the profile folders"), std::string::npos) << error;
    EXPECT_EQ(error.find("bytes"), std::string::npos) << error;
    std::string words = error.substr(error.find("cannot load table"));
    words = words.substr(0, words.find(", got '"));  // the file as the client wrote it
    if (refusal.empty()) refusal = words;
    EXPECT_EQ(words, refusal) << "the answer differs with the file: " << file;
  }
  const std::string entry =
      "{profile: generic-404, interface: vcan0, node_id: 0x30, name: t, physics: {pressure: "
      "{table: {csv: " +
      secret + ", value_unit: bar}}}}";
  EXPECT_EQ(add_nodes(entry), "io.cansim.Error.Config");
  EXPECT_NE(error.find("cannot load table: expected a file in the profile folders"), std::string::npos) << error;
  fleet.allow_folder(dir.path);  // the same file in a profile folder is read
  EXPECT_EQ(set_model("table: {csv: " + secret + ", value_unit: bar}"), "") << error;
  EXPECT_EQ(set_model("table: {csv: " + big + "}"), "io.cansim.Error.InvalidArgument");
  EXPECT_NE(error.find("bytes; expected at most"), std::string::npos) << error;
}

// ---------------------------------------------------------------- memory

// 1,000 AddNodes / RemoveNode cycles give back what they took (each kept
// about 66 KB before: the fragment and its profile). A small profile keeps
// the cycles quick.
TEST(NoLeak, AThousandAddRemoveCyclesKeepTheHeapFlat) {
#ifdef CANSIM_ASAN
  GTEST_SKIP() << "mallinfo2 does not see AddressSanitizer's heap (LeakSanitizer checks this build)";
#endif
  TempDir dir;
  std::ofstream(dir.path + "/mini.yaml")
      << "name: mini\nnode_id: 5\nobjects:\n"
         "  - {index: 0x1000, type: UNSIGNED32, access: ro, default: 0x00020194}\n"
         "  - {index: 0x1001, type: UNSIGNED8, access: ro, default: 0}\n"
         "  - {index: 0x1017, type: UNSIGNED16, access: rw, default: 0}\n"
         "  - {index: 0x1018, sub: 0, kind: record, type: UNSIGNED8, access: ro, default: 4}\n"
         "  - {index: 0x1018, sub: 1..4, kind: record, type: UNSIGNED32, access: ro, default: 1}\n";
  daemon::DaemonSettings settings;
  settings.state_dir = dir.path + "/state";
  settings.config_file = dir.path + "/fleet.yaml";  // AddNodes takes profiles from its folder
  daemon::Daemon d(settings);
  const auto previous = spdlog::default_logger();
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("off"));  // no sink: nothing kept
  const std::string entry = "{profile: " + dir.path + "/mini.yaml, interface: cansimlk0, node_id: 0x40, name: cycle}";
  auto cycle = [&] {
    d.add_nodes(entry);
    d.remove_node("cansimlk0/cycle/0");
  };
  for (int i = 0; i < 50; ++i) cycle();  // caches, pools and the log sink at their size
  const std::size_t before = mallinfo2().uordblks;
  for (int i = 0; i < 1000; ++i) cycle();
  const std::size_t after = mallinfo2().uordblks;
  spdlog::set_default_logger(previous);
  EXPECT_LT(after, before + 64 * 1024) << "heap in use grew by " << (after - before) << " bytes";
}

// ---------------------------------------------------------------- connections

// The daemon's endpoints on a socket in a temp dir, stepped by hand with the
// clients (one thread).
class Endpoints : public ::testing::Test {
 protected:
  TempDir dir;
  test::ControlFleet fleet{kFleet};
  io::EventLoop loop;
  control::ControlEndpoints endpoints{loop, fleet.service(), 2};
  std::string socket = dir.path + "/control";
  std::vector<sd_bus*> clients;

  Endpoints() {
    EXPECT_TRUE(loop.open()) << loop.error();
    endpoints.listen(socket);
  }
  ~Endpoints() override {
    for (sd_bus* c : clients) sd_bus_close_unref(c);
  }
  void step() {
    bool timer = false;
    int signal = 0;
    endpoints.before_sleep(kNever);
    loop.wait(0, timer, signal);
    endpoints.process();
    for (sd_bus* c : clients) sd_bus_process(c, nullptr);
  }
  sd_bus* connect() {
    sd_bus* c = nullptr;
    sd_bus_new(&c);
    sd_bus_set_address(c, ("unix:path=" + socket).c_str());
    EXPECT_GE(sd_bus_start(c), 0);
    clients.push_back(c);
    return c;
  }
  // Calls ListNodes on `c`; "" on success, else the error name (message in `message`).
  std::string list(sd_bus* c, std::string* message = nullptr) {
    struct Result {
      bool done = false;
      std::string name, message;
    } result;
    sd_bus_message* m = nullptr;
    sd_bus_message_new_method_call(c, &m, nullptr, control::kRootPath, control::kFleetInterface, "ListNodes");
    sd_bus_call_async(
        c, nullptr, m,
        [](sd_bus_message* r, void* p, sd_bus_error*) -> int {
          auto& res = *static_cast<Result*>(p);
          res.done = true;
          if (const sd_bus_error* e = sd_bus_message_get_error(r)) res.name = e->name, res.message = e->message;
          return 1;
        },
        &result, 0);
    sd_bus_message_unref(m);
    for (int i = 0; i < 2000 && !result.done; ++i) step();
    if (message) *message = result.message;
    return result.done ? result.name : "no answer";
  }
  void step_until(const std::function<bool()>& done, TimeUs for_us) {
    const TimeUs until = io::monotonic_now() + for_us;
    while (!done() && io::monotonic_now() < until) {
      step();
      ::usleep(1000);
    }
  }
};

TEST_F(Endpoints, OneClientTooManyIsToldWhy) {
  CapturedLog log;
  sd_bus* a = connect();
  sd_bus* b = connect();
  EXPECT_EQ(list(a), "");
  EXPECT_EQ(list(b), "");
  std::string message;
  EXPECT_EQ(list(connect(), &message), "org.freedesktop.DBus.Error.LimitsExceeded");
  EXPECT_EQ(message,
            "cansimd serves at most 2 control clients at once (cansimd --max-clients); try again when one "
            "has disconnected");
  std::vector<sd_bus*> burst;
  for (int i = 0; i < 20; ++i) burst.push_back(connect());  // a burst of more: one warning line
  // Each of the burst closed by cansimd: none left in the listen backlog to
  // take the slot the next client is meant to get.
  const auto burst_gone = [&] {
    return std::all_of(burst.begin(), burst.end(), [](sd_bus* c) { return sd_bus_is_open(c) <= 0; });
  };
  step_until([&] { return burst_gone() && endpoints.connections() == 2; }, 10'000'000);
  EXPECT_TRUE(burst_gone());
  EXPECT_EQ(endpoints.connections(), 2u);  // the refused ones are gone
  EXPECT_EQ(log.count("refusing another"), 1u) << log.text.str();
  sd_bus_close(a);
  step_until([&] { return endpoints.connections() == 1; }, 1'000'000);
  EXPECT_EQ(list(connect()), "");
}

TEST_F(Endpoints, AHandshakeNeverFinishedIsDropped) {
  CapturedLog log;
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, socket.c_str(), sizeof addr.sun_path - 1);
  ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  step_until([&] { return endpoints.connections() == 1; }, 1'000'000);
  ASSERT_EQ(endpoints.connections(), 1u);
  step_until([&] { return endpoints.connections() == 0; }, limits::kAuthTimeoutUs + 1'000'000);
  EXPECT_EQ(endpoints.connections(), 0u);
  EXPECT_EQ(log.count("dropped: did not finish the D-Bus handshake in time"), 1u) << log.text.str();
  ::close(fd);
}

// A connection that finished its handshake but makes no call holds a slot
// for nothing: closed after the first-call time (64 such locked everyone out).
TEST(IdleEndpoints, AConnectionThatMakesNoCallIsClosed) {
  TempDir dir;
  test::ControlFleet fleet{kFleet};
  io::EventLoop loop;
  ASSERT_TRUE(loop.open()) << loop.error();
  control::ControlEndpoints endpoints{loop, fleet.service(), 4, 300'000};
  endpoints.listen(dir.path + "/control");
  CapturedLog log;
  sd_bus* idle = nullptr;
  sd_bus_new(&idle);
  sd_bus_set_address(idle, ("unix:path=" + dir.path + "/control").c_str());
  ASSERT_GE(sd_bus_start(idle), 0);
  const TimeUs until = io::monotonic_now() + 5'000'000;
  bool was_ready = false;
  while (io::monotonic_now() < until && (endpoints.connections() > 0 || !was_ready)) {
    bool timer = false;
    int signal = 0;
    endpoints.before_sleep(kNever);
    loop.wait(0, timer, signal);
    endpoints.process();
    sd_bus_process(idle, nullptr);
    was_ready |= sd_bus_is_ready(idle) > 0;
    ::usleep(1000);
  }
  EXPECT_TRUE(was_ready);
  EXPECT_EQ(endpoints.connections(), 0u);
  EXPECT_EQ(log.count("dropped: made no call in time"), 1u) << log.text.str();
  sd_bus_close_unref(idle);
}

// One uid holds at most 3 of 4 slots (a quarter kept for other users and
// root): its raw sockets (never a handshake) leave root a slot, and its
// fourth is told why.
TEST_F(Endpoints, OneUserLeavesAShareOfTheSlotsToOthers) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to connect as another uid";
  control::ControlEndpoints four{loop, fleet.service(), 4};
  const std::string path = dir.path + "/four";
  four.listen(path);
  ::chmod(dir.path.c_str(), 0755);
  ::chmod(path.c_str(), 0666);
  int ready[2], done[2];
  ASSERT_EQ(::pipe(ready), 0);
  ASSERT_EQ(::pipe(done), 0);
  const pid_t child = ::fork();
  if (child == 0) {  // uid 65534: five raw connections, held until told
    ::close(ready[0]);
    ::close(done[1]);
    if (::setresgid(65534, 65534, 65534) != 0 || ::setresuid(65534, 65534, 65534) != 0) ::_exit(2);
    for (int i = 0; i < 5; ++i) {
      const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
      sockaddr_un addr{};
      addr.sun_family = AF_UNIX;
      std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
      if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) ::_exit(3);
    }
    char c = 'r';
    if (::write(ready[1], &c, 1) != 1) ::_exit(4);
    (void)::read(done[0], &c, 1);
    ::_exit(0);
  }
  ::close(ready[1]);
  ::close(done[0]);
  char c = 0;
  if (::read(ready[0], &c, 1) != 1) {
    int status = 0;
    ::waitpid(child, &status, 0);
    FAIL() << "the uid 65534 child could not connect: exit " << WEXITSTATUS(status);
  }
  const auto pass = [&] {
    bool timer = false;
    int signal = 0;
    four.before_sleep(kNever);
    loop.wait(0, timer, signal);
    four.process();
  };
  CapturedLog log;
  for (int i = 0; i < 50 && log.count("are kept for other users and root") == 0; ++i) {
    pass();
    ::usleep(1000);
  }
  EXPECT_EQ(log.count("control socket: uid 65534 holds 3 of the 4 control client slots, all one user may (the other "
                      "1 are kept for other users and root): refusing another"),
            1u)
      << log.text.str();
  sd_bus* root = nullptr;
  sd_bus_new(&root);
  sd_bus_set_address(root, ("unix:path=" + path).c_str());
  ASSERT_GE(sd_bus_start(root), 0);
  sd_bus_message* m = nullptr;
  sd_bus_message_new_method_call(root, &m, nullptr, control::kRootPath, control::kFleetInterface, "ListNodes");
  bool answered = false;
  std::string error;
  sd_bus_call_async(
      root, nullptr, m,
      [](sd_bus_message* r, void* p, sd_bus_error*) -> int {
        *static_cast<bool*>(p) = !sd_bus_message_is_method_error(r, nullptr);
        return 1;
      },
      &answered, 0);
  sd_bus_message_unref(m);
  for (int i = 0; i < 2000 && !answered; ++i) {
    pass();
    sd_bus_process(root, nullptr);
  }
  EXPECT_TRUE(answered) << "root was not served beside uid 65534's connections";
  sd_bus_close_unref(root);
  ::close(done[1]);
  int status = 0;
  ::waitpid(child, &status, 0);
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

// A client that sends a stream of costly calls (each AddNodes loads a profile
// and builds nodes) gets them served a few per pass, the nodes running in
// between: before, up to 32 went in one pass (2.4 s of loop in the VM).
TEST_F(Endpoints, CostlyCallsDoNotHoldThePass) {
  sd_bus* c = connect();
  EXPECT_EQ(list(c), "");
  int answered = 0;
  for (int i = 0; i < 8; ++i) {
    sd_bus_message* m = nullptr;
    sd_bus_message_new_method_call(c, &m, nullptr, control::kRootPath, control::kFleetInterface, "AddNodes");
    const std::string yaml =
        "{profile: generic-404, interface: vb" + std::to_string(i) + ", node_id: 1, count: 16, name: p}";
    sd_bus_message_append(m, "s", yaml.c_str());
    sd_bus_call_async(
        c, nullptr, m,
        [](sd_bus_message*, void* n, sd_bus_error*) -> int {
          ++*static_cast<int*>(n);
          return 1;
        },
        &answered, 0);
    sd_bus_message_unref(m);
  }
  sd_bus_flush(c);
  bool timer = false;
  int signal = 0;
  loop.wait(0, timer, signal);
  endpoints.process();  // one pass
  while (sd_bus_process(c, nullptr) > 0) {
  }
  EXPECT_LT(answered, 8);
  step_until([&] { return answered == 8; }, 10'000'000);
  EXPECT_EQ(answered, 8);
  EXPECT_EQ(fleet.nodes().size(), 1u + 8 * 16);
}

// A subscriber that never reads: its signals pile up to the bound, then it is
// dropped (it pinned about 505 MB before).
TEST_F(Endpoints, ASubscriberThatNeverReadsIsDropped) {
  CapturedLog log;
  sd_bus* reader = connect();
  sd_bus* sleeper = connect();
  EXPECT_EQ(list(reader), "");
  sd_bus_message* m = nullptr;
  sd_bus_message_new_method_call(sleeper, &m, nullptr, control::kRootPath, control::kFleetInterface, "Subscribe");
  sd_bus_send(sleeper, m, nullptr);
  sd_bus_message_unref(m);
  step_until([] { return false; }, 50'000);
  clients.erase(std::find(clients.begin(), clients.end(), sleeper));  // not processed from now on
  const io::NodeRef ref = fleet.node("vcan0/g/0").ref;
  for (int i = 0; i < 40'000 && endpoints.connections() == 2; ++i) {
    fleet.service().on_power(ref, i % 2, 0);  // a PropertiesChanged signal each
    if (i % 64 == 0) step();
  }
  step();
  EXPECT_EQ(endpoints.connections(), 1u);
  EXPECT_EQ(log.count("dropped: reads too slowly"), 1u) << log.text.str();
  EXPECT_EQ(list(reader), "");  // the others are served on
  sd_bus_close_unref(sleeper);
}

}  // namespace
}  // namespace cansim
