// cansimctl without a daemon: command lines -> method calls, value typing,
// object addresses, durations, endpoints, and the printed output.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <sstream>

#include "ctl/args.hpp"
#include "ctl/commands.hpp"
#include "ctl/connection.hpp"
#include "ctl/decode.hpp"
#include "ctl/json.hpp"
#include "ctl/output.hpp"
#include "ctl/targets.hpp"

namespace cansim::ctl {
namespace {

Request parse(std::vector<std::string> args) { return parse_command_line(args).request; }

Arg s(const char* text) { return Value(std::string(text)); }
Arg d(double v) { return Value(v); }

Call node_call(const char* method, std::vector<Arg> args = {}) {
  return {Target::kNode, kNodeInterface, method, std::move(args)};
}

Call fleet_call(const char* method, std::vector<Arg> args = {}) {
  return {Target::kFleet, kFleetInterface, method, std::move(args)};
}

void expect_usage_error(std::vector<std::string> args) {
  EXPECT_THROW(parse_command_line(args), UsageError) << ::testing::PrintToString(args);
}

// ---------------------------------------------------------------- verbs

TEST(CtlArgs, FleetVerbs) {
  EXPECT_EQ(parse({"list"}).call, fleet_call("ListNodes"));
  EXPECT_EQ(parse({"list"}).output, Output::kNodes);
  EXPECT_EQ(parse({"reload"}).call, fleet_call("Reload"));
  EXPECT_EQ(parse({"stats"}).call, fleet_call("GetBusStatistics"));
  EXPECT_EQ(parse({"stats"}).output, Output::kStats);
  EXPECT_EQ(parse({"remove", "dps"}).call, fleet_call("RemoveNode", {s("dps")}));
  EXPECT_EQ(parse({"remove", "dps"}).node, "dps");  // RemoveNode resolves the name; the answer names its key

  Request time = parse({"time"});
  EXPECT_EQ(time.call, (Call{Target::kFleet, kPropertiesInterface, "Get", {s(kFleetInterface), s("SimulatedTime")}}));
  EXPECT_EQ(time.output, Output::kTime);

  Request add = parse({"add", "more.yaml"});
  EXPECT_EQ(add.call, fleet_call("AddNodes"));  // the file's text is added when run
  EXPECT_EQ(add.file, "more.yaml");
  EXPECT_EQ(add.output, Output::kAdded);
}

TEST(CtlArgs, StatusGetsAllNodeProperties) {
  Request r = parse({"status", "vcan0/0x10"});
  EXPECT_EQ(r.node, "vcan0/0x10");
  EXPECT_EQ(r.call, (Call{Target::kNode, kPropertiesInterface, "GetAll", {s(kNodeInterface)}}));
  EXPECT_EQ(r.output, Output::kStatus);
}

TEST(CtlArgs, SetStepsOrRamps) {
  Request step = parse({"set", "dps", "pressure", "5", "bar"});
  EXPECT_EQ(step.node, "dps");
  EXPECT_EQ(step.call, node_call("Step", {s("pressure"), d(5), s("bar")}));
  EXPECT_EQ(parse({"set", "dps", "temperature", "-5.5", "degC", "--ramp", "500ms"}).call,
            node_call("Ramp", {s("temperature"), d(-5.5), s("degC"), d(0.5)}));
  EXPECT_EQ(parse({"set", "--ramp=2 min", "dps", "pressure", "1", "bar"}).call,
            node_call("Ramp", {s("pressure"), d(1), s("bar"), d(120)}));
  EXPECT_EQ(parse({"hold", "dps", "pressure"}).call, node_call("Hold", {s("pressure")}));
  EXPECT_EQ(parse({"model", "dps", "pressure", "{sine: {amplitude: 1 bar}}"}).call,
            node_call("SetModel", {s("pressure"), s("{sine: {amplitude: 1 bar}}")}));
  EXPECT_EQ(parse({"model", "dps", "pressure", "- constant: 4 bar\n- sine: {amplitude: 1 bar}"}).call,
            node_call("SetModel", {s("pressure"), s("- constant: 4 bar\n- sine: {amplitude: 1 bar}")}));
  EXPECT_EQ(parse({"restore-model", "dps", "temperature"}).call, node_call("RestoreModel", {s("temperature")}));
}

TEST(CtlArgs, OverrideAndItsEnd) {
  EXPECT_EQ(parse({"override", "dps", "pressure", "3", "bar"}).call,
            node_call("Override", {s("pressure"), d(3), s("bar")}));
  EXPECT_EQ(parse({"override", "dps", "pressure", "--off"}).call, node_call("ClearOverride", {s("pressure")}));
  // No channel: every channel of the node ("" to ClearOverride).
  EXPECT_EQ(parse({"override", "dps", "--off"}).call, node_call("ClearOverride", {s("")}));
  EXPECT_EQ(parse({"override", "'generic/*'", "--off"}).group, true);
  expect_usage_error({"override", "dps", "pressure", "3", "--off"});
  expect_usage_error({"override", "dps", "pressure", "3"});
  expect_usage_error({"override", "dps"});
  EXPECT_EQ(parse({"override", "dps", "--off"}).verb, "override");
}

TEST(CtlArgs, FaultMapsOptionsToParameters) {
  Request r = parse({"fault", "dps", "drift", "--for", "10s", "--at=1.5", "rate=0.1 bar/s", "channel=pressure"});
  StringMap params{{"duration", "10 s"}, {"at", "1.5 s"}, {"rate", "0.1 bar/s"}, {"channel", "pressure"}};
  EXPECT_EQ(r.call, node_call("ArmFault", {s("drift"), params}));
  EXPECT_EQ(r.output, Output::kFaultId);
  EXPECT_EQ(parse({"fault", "dps", "power_loss"}).call, node_call("ArmFault", {s("power_loss"), StringMap{}}));
}

TEST(CtlArgs, FaultListCancelPowerCycleNmt) {
  EXPECT_EQ(parse({"faults", "dps"}).call, node_call("ListFaults"));
  EXPECT_EQ(parse({"faults", "dps"}).output, Output::kFaults);
  EXPECT_EQ(parse({"cancel", "dps", "3"}).call, node_call("CancelFault", {Value(std::uint32_t(3))}));
  EXPECT_EQ(parse({"power-cycle", "dps"}).call, node_call("PowerCycle", {d(0.5)}));  // as Node.power_cycle()
  EXPECT_EQ(parse({"power-cycle", "dps", "--off", "2 s"}).call, node_call("PowerCycle", {d(2)}));
  // CiA 301's names go to the daemon as they are; the short aliases become them.
  for (const char* c : {"start", "stop", "pre-operational", "reset-node", "reset-communication"})
    EXPECT_EQ(parse({"nmt", "dps", c}).call, node_call("Nmt", {s(c)}));
  EXPECT_EQ(parse({"nmt", "dps", "preop"}).call, node_call("Nmt", {s("pre-operational")}));
  EXPECT_EQ(parse({"nmt", "dps", "reset"}).call, node_call("Nmt", {s("reset-node")}));
  EXPECT_EQ(parse({"nmt", "dps", "reset-comm"}).call, node_call("Nmt", {s("reset-communication")}));
}

TEST(CtlArgs, DcfPrintsOrWritesAFile) {
  Request printed = parse({"dcf", "dps"});
  EXPECT_EQ(printed.call, node_call("GetDcf"));
  EXPECT_EQ(printed.output, Output::kDcf);
  EXPECT_EQ(printed.file, "");
  EXPECT_EQ(parse({"dcf", "dps", "--output", "dps.dcf"}).file, "dps.dcf");
  expect_usage_error({"dcf"});
}

TEST(CtlArgs, ReadAndWriteObjects) {
  Request read = parse({"read", "dps", "0x6130:1"});
  EXPECT_EQ(read.call, node_call("Read", {Value(std::uint16_t(0x6130)), Value(std::uint8_t(1))}));
  EXPECT_EQ(read.object, (ObjectAddress{0x6130, 1}));
  EXPECT_EQ(read.output, Output::kValue);

  EXPECT_EQ(parse({"write", "dps", "0x1017", "1000"}).call,
            node_call("Write", {Value(std::uint16_t(0x1017)), Value(std::uint8_t(0)), Variant{std::int64_t(1000)}}));
  EXPECT_EQ(parse({"write", "dps", "0x1017", "1000", "--type", "u16"}).call,
            node_call("Write", {Value(std::uint16_t(0x1017)), Value(std::uint8_t(0)), Variant{std::uint16_t(1000)}}));
  EXPECT_EQ(parse({"write", "dps", "0x1008", "--type=str", "12"}).call,
            node_call("Write", {Value(std::uint16_t(0x1008)), Value(std::uint8_t(0)), Variant{std::string("12")}}));
}

TEST(CtlArgs, RecordStoreRestore) {
  Request r = parse({"record", "dps", "out/dps.csv"});
  ASSERT_EQ(r.call.method, "StartRecording");
  std::string path = std::get<std::string>(std::get<Value>(r.call.args.at(0)));
  EXPECT_EQ(path.front(), '/');  // the daemon's working directory is not ours
  EXPECT_TRUE(path.ends_with("/out/dps.csv")) << path;
  EXPECT_EQ(parse({"record", "dps", "--stop"}).call, node_call("StopRecording"));

  EXPECT_EQ(parse({"store", "dps"}).call, node_call("Store", {Value(std::uint8_t(1))}));
  EXPECT_EQ(parse({"store", "dps", "2"}).call, node_call("Store", {Value(std::uint8_t(2))}));
  EXPECT_EQ(parse({"restore", "dps", "0x4"}).call, node_call("Restore", {Value(std::uint8_t(4))}));
  EXPECT_EQ(parse({"store", "dps", "127"}).call, node_call("Store", {Value(std::uint8_t(127))}));
}

TEST(CtlArgs, WatchSubscribesForTheFleetOrOneNode) {
  Request all = parse({"watch"});
  EXPECT_EQ(all.call, fleet_call("Subscribe"));
  EXPECT_EQ(all.output, Output::kWatch);
  EXPECT_EQ(all.node, "");
  EXPECT_EQ(parse({"watch", "generic/1"}).node, "generic/1");
}

TEST(CtlArgs, GlobalOptionsAnywhere) {
  CommandLine line = parse_command_line({"--json", "list", "--timeout", "2.5", "--socket=/tmp/c"});
  EXPECT_TRUE(line.global.json);
  EXPECT_EQ(line.global.timeout_s, 2.5);
  EXPECT_EQ(line.global.bus, BusKind::kSocket);
  EXPECT_EQ(line.global.socket, "/tmp/c");
  EXPECT_EQ(parse_command_line({"--system", "list"}).global.bus, BusKind::kSystem);
  EXPECT_EQ(parse_command_line({"list", "--user"}).global.bus, BusKind::kUser);
  EXPECT_TRUE(parse_command_line({"-h"}).global.help);
  EXPECT_TRUE(parse_command_line({"set", "--help"}).global.help);  // help wins over an incomplete line
  EXPECT_TRUE(parse_command_line({"--version"}).global.version);
}

TEST(CtlArgs, NegativeNumbersAndDoubleDashArePositional) {
  EXPECT_EQ(parse({"set", "dps", "temperature", "-.5", "degC"}).call,
            node_call("Step", {s("temperature"), d(-0.5), s("degC")}));
  EXPECT_EQ(parse({"write", "dps", "0x2000", "--", "-text"}).call,
            node_call("Write", {Value(std::uint16_t(0x2000)), Value(std::uint8_t(0)), Variant{std::string("-text")}}));
}

TEST(CtlArgs, BadLinesAreUsageErrors) {
  expect_usage_error({});
  expect_usage_error({"--json"});
  expect_usage_error({"frobnicate"});
  expect_usage_error({"list", "extra"});
  expect_usage_error({"status"});
  expect_usage_error({"status", "a", "b"});
  expect_usage_error({"set", "dps", "pressure", "5"});
  expect_usage_error({"set", "dps", "humidity", "5", "%"});
  expect_usage_error({"set", "dps", "pressure", "five", "bar"});
  expect_usage_error({"set", "dps", "pressure", "5", "bar", "--ramp"});
  expect_usage_error({"set", "dps", "pressure", "5", "bar", "--ramp", "soon"});
  expect_usage_error({"set", "dps", "pressure", "5", "bar", "--ramp", "1s", "--ramp", "2s"});
  expect_usage_error({"set", "dps", "pressure", "5", "bar", "--ramp", "-1s"});
  expect_usage_error({"hold", "dps", "pressure", "--off"});  // not an option of hold
  expect_usage_error({"override", "dps", "pressure", "3"});
  expect_usage_error({"override", "dps", "pressure", "3", "bar", "--off"});
  expect_usage_error({"override", "dps", "pressure", "--off=yes"});
  expect_usage_error({"fault", "dps"});
  expect_usage_error({"fault", "dps", "drift", "rate"});
  expect_usage_error({"fault", "dps", "drift", "=1"});
  expect_usage_error({"fault", "dps", "drift", "--for", "1 s", "duration=2 s"});
  expect_usage_error({"fault", "dps", "drift", "--at", "tomorrow"});
  expect_usage_error({"cancel", "dps", "x"});
  expect_usage_error({"cancel", "dps", "4294967296"});
  expect_usage_error({"power-cycle", "dps", "--off", "1 day"});
  expect_usage_error({"nmt", "dps", "go"});
  expect_usage_error({"read", "dps", "0x10000"});
  expect_usage_error({"read", "dps", "0x1017:256"});
  expect_usage_error({"read", "dps", "index"});
  expect_usage_error({"write", "dps", "0x1017"});
  expect_usage_error({"write", "dps", "0x1017", "70000", "--type", "u16"});
  expect_usage_error({"write", "dps", "0x1017", "1", "--type", "u12"});
  expect_usage_error({"write", "dps", "0x1017", "99999999999999999999"});
  expect_usage_error({"record", "dps"});
  expect_usage_error({"record", "dps", "f.csv", "--stop"});
  expect_usage_error({"store", "dps", "256"});
  expect_usage_error({"store", "dps", "128"});  // the daemon takes 1..127: said here, not after the call
  expect_usage_error({"restore", "dps", "0"});
  expect_usage_error({"watch", "a", "b"});
  expect_usage_error({"add"});
  expect_usage_error({"list", "--socket"});
  expect_usage_error({"list", "--socket", "/a", "--system"});
  expect_usage_error({"list", "--system", "--user"});
  expect_usage_error({"list", "--timeout", "0"});
  expect_usage_error({"list", "--timeout", "soon"});
  expect_usage_error({"list", "--json=yes"});
  expect_usage_error({"--ramp", "1s", "list"});
}

TEST(CtlArgs, MainExitCodes) {
  std::ostringstream out, err;
  EXPECT_EQ(cansimctl_main({"set", "dps"}, out, err), 2);
  EXPECT_EQ(out.str(), "");
  // Only that verb's usage.
  EXPECT_EQ(err.str(),
            "cansimctl: set: 1 argument given, expected 4\n\n"
            "usage: cansimctl set NODE CHANNEL VALUE UNIT [--ramp DURATION]\n"
            "Try 'cansimctl set --help' for more.\n");
  std::ostringstream bad_channel;
  EXPECT_EQ(cansimctl_main({"hold", "dps", "humidity"}, out, bad_channel), 2);
  EXPECT_TRUE(
      bad_channel.str().starts_with("cansimctl: channel must be pressure or temperature, got 'humidity'\n\n"
                                    "usage: cansimctl hold NODE CHANNEL\n"))
      << bad_channel.str();
  // No verb known: the whole usage.
  std::ostringstream unknown;
  EXPECT_EQ(cansimctl_main({"frobnicate"}, out, unknown), 2);
  EXPECT_NE(unknown.str().find("\nusage: cansimctl [OPTIONS] COMMAND"), std::string::npos) << unknown.str();
  // With --json, one JSON object on stderr.
  std::ostringstream json_err;
  EXPECT_EQ(cansimctl_main({"--json", "set", "dps"}, out, json_err), 2);
  EXPECT_EQ(json_err.str(), "{\"error\":\"set: 1 argument given, expected 4\",\"name\":null,\"exit_status\":2}\n");

  std::ostringstream help;
  EXPECT_EQ(cansimctl_main({"--help"}, help, err), 0);
  EXPECT_EQ(help.str(), usage_text());
  std::ostringstream version;
  EXPECT_EQ(cansimctl_main({"--version"}, version, err), 0);
  EXPECT_TRUE(version.str().starts_with("cansimctl ")) << version.str();

  std::ostringstream none, refused;
  EXPECT_EQ(cansimctl_main({"--socket", "/nonexistent/control", "list"}, none, refused), 1);
  EXPECT_TRUE(refused.str().starts_with("cansimctl: cannot connect to the control socket /nonexistent/control"))
      << refused.str();
  std::ostringstream refused_json;
  EXPECT_EQ(cansimctl_main({"--socket", "/nonexistent/control", "--json", "list"}, none, refused_json), 1);
  EXPECT_TRUE(refused_json.str().starts_with("{\"error\":\"cannot connect to the control socket /nonexistent/"))
      << refused_json.str();
  EXPECT_TRUE(refused_json.str().ends_with(",\"name\":null,\"exit_status\":1}\n")) << refused_json.str();
}

TEST(CtlArgs, EachVerbHasItsHelp) {
  for (const std::string& verb : verb_names()) {
    std::ostringstream help, err;
    EXPECT_EQ(cansimctl_main({verb, "--help"}, help, err), 0) << verb;
    EXPECT_TRUE(help.str().starts_with("usage: cansimctl " + verb)) << help.str();
    EXPECT_EQ(help.str(), verb_help(verb));
    std::ostringstream same;
    EXPECT_EQ(cansimctl_main({"help", verb}, same, err), 0) << verb;
    EXPECT_EQ(same.str(), help.str());
  }
  // What a verb's arguments are, and only those.
  EXPECT_NE(verb_help("set").find("\nUNIT: bar, mbar, psi"), std::string::npos);
  EXPECT_NE(verb_help("set").find("an ID range (vcan0/0x10-0x13)"), std::string::npos) << "set takes groups";
  EXPECT_EQ(verb_help("status").find("ID range"), std::string::npos) << "status takes one node";
  EXPECT_EQ(verb_help("list").find("NODE:"), std::string::npos);
  EXPECT_NE(verb_help("fault").find("\nKIND: open, short, stuck, drift"), std::string::npos);
  EXPECT_NE(verb_help("read").find("= 3.50 bar"), std::string::npos);
  std::ostringstream out, err;
  EXPECT_EQ(cansimctl_main({"help", "nope"}, out, err), 2);
  EXPECT_EQ(cansimctl_main({"help", "a", "b"}, out, err), 2);
}

TEST(CtlArgs, ActingVerbsTakeGroups) {
  for (const char* verb : {"set", "override", "fault", "cancel", "power-cycle", "nmt"}) {
    std::vector<std::string> line = {verb, "generic/*"};
    if (std::string(verb) == "set" || std::string(verb) == "override")
      line.insert(line.end(), {"pressure", "1", "bar"});
    if (std::string(verb) == "fault") line.push_back("open");
    if (std::string(verb) == "cancel") line.push_back("3");
    if (std::string(verb) == "nmt") line.push_back("start");
    EXPECT_TRUE(parse(line).group) << verb;
  }
  EXPECT_FALSE(parse({"status", "generic/*"}).group);
  EXPECT_FALSE(parse({"read", "dps", "0x1017"}).group);
}

std::vector<NodeRow> rows() {
  auto row = [](std::string key, std::string name, std::uint8_t id) {
    NodeRow r;
    r.key = key;
    r.path = "/p/" + key;
    r.name = std::move(name);
    r.interface = key.substr(0, key.find('/'));
    r.node_id = id;
    return r;
  };
  return {row("vcan0/dps/0", "dps", 0x7F), row("vcan0/generic/0", "generic", 0x10),
          row("vcan0/generic/10", "generic", 0x1A), row("vcan0/generic/2", "generic", 0x12),
          row("vcan1/generic-b/0", "generic-b", 0x10)};
}

std::vector<std::string> keys(const std::optional<std::vector<NodeRow>>& targets) {
  std::vector<std::string> out;
  if (targets)
    for (const NodeRow& r : *targets) out.push_back(r.key);
  return out;
}

TEST(CtlTargets, GlobsRangesAndCountGroups) {
  using K = std::vector<std::string>;
  EXPECT_EQ(keys(group_targets("generic/*", rows())), (K{"vcan0/generic/0", "vcan0/generic/2", "vcan0/generic/10"}));
  EXPECT_EQ(keys(group_targets("generic", rows())), (K{"vcan0/generic/0", "vcan0/generic/2", "vcan0/generic/10"}));
  EXPECT_EQ(keys(group_targets("vcan0/0x10-0x12", rows())), (K{"vcan0/generic/0", "vcan0/generic/2"}));
  EXPECT_EQ(keys(group_targets("vcan1/16-16", rows())), (K{"vcan1/generic-b/0"}));
  EXPECT_EQ(keys(group_targets("vcan1/*", rows())), (K{"vcan1/generic-b/0"}));
  EXPECT_EQ(keys(group_targets("generic*", rows())),
            (K{"vcan0/generic/0", "vcan0/generic/2", "vcan0/generic/10", "vcan1/generic-b/0"}));
  ASSERT_TRUE(group_targets("nothing/*", rows()));
  EXPECT_TRUE(group_targets("nothing/*", rows())->empty());
  // One node: the daemon resolves it (GetNode).
  EXPECT_FALSE(group_targets("dps", rows()));
  EXPECT_FALSE(group_targets("generic/2", rows()));
  EXPECT_FALSE(group_targets("vcan0/0x10", rows()));
  EXPECT_FALSE(group_targets("vcan0/dps/0", rows()));
  EXPECT_FALSE(group_targets("vcan1/generic-b", rows()));
}

TEST(CtlOutput, GroupResultsPerNode) {
  std::vector<GroupResult> results = {{"vcan0/generic/0", true, 3, ""}, {"vcan0/generic/1", false, {}, "no way"}};
  std::ostringstream text, json;
  Printer(text, false).group(results);
  EXPECT_EQ(text.str(), "NODE             RESULT\nvcan0/generic/0  3\nvcan0/generic/1  refused: no way\n");
  Printer(json, true).group(results);
  EXPECT_EQ(json.str(), R"j([{"node":"vcan0/generic/0","ok":true,"id":3},)j"
                        R"j({"node":"vcan0/generic/1","ok":false,"error":"no way"}])j"
                        "\n");
}

TEST(CtlOutput, ReadOfAProcessValuePrintsItsUnit) {
  ObjectInfo real{0x6130, 1, "AI input PV 1", "REAL32", 1.0, "bar"};
  ObjectInfo integer{0x7130, 1, "AI input PV 1 (INTEGER16)", "INTEGER16", 0.01, "bar"};
  ObjectInfo plain{0x1017, 0, "Producer heartbeat time", "UNSIGNED16", 1.0, ""};
  ObjectInfo pascal{0x6130, 1, "AI input PV 1", "REAL32", 1.0, "Pa"};
  std::ostringstream out;
  Printer p(out, false);
  p.value("vcan0/generic/0", {0x6130, 1}, Value(3.5), &real);
  p.value("vcan0/generic/0", {0x7130, 1}, Value(std::int16_t(350)), &integer);
  p.value("vcan0/generic/0", {0x1017, 0}, Value(std::uint16_t(1000)), &plain);
  p.value("vcan0/p92c/0", {0x6130, 1}, Value(9990440.0), &pascal);
  EXPECT_EQ(out.str(), "3.5 bar\n350 (0x15e) = 3.50 bar\n1000 (0x3e8)\n9 990 440 Pa\n");
  // JSON: the value it means in its unit, the raw value, the CiA type (not a D-Bus letter).
  std::ostringstream json;
  Printer(json, true).value("vcan0/generic/0", {0x7130, 1}, Value(std::int16_t(350)), &integer);
  EXPECT_EQ(json.str(), R"j({"node":"vcan0/generic/0","index":28976,"sub":1,"name":"AI input PV 1 (INTEGER16)",)j"
                        R"j("type":"INTEGER16","value":3.5,"unit":"bar","raw":350,"counts":null})j"
                        "\n");
  // A device whose PV is counts (the SMC by default): counts, and what they mean beside them.
  ObjectInfo counts{0x6130, 1, "Process value (REAL32)", "REAL32", 1.0, "counts", CountScaling{0.00025, 0.0, "bar"}};
  std::ostringstream smc, smc_json;
  Printer(smc, false).value("vcan0/smc/0", {0x6130, 1}, Value(10008.0), &counts);
  EXPECT_EQ(smc.str(), "10 008 counts = 2.502 bar\n");
  Printer(smc_json, true).value("vcan0/smc/0", {0x6130, 1}, Value(10008.0), &counts);
  EXPECT_EQ(smc_json.str(),
            R"j({"node":"vcan0/smc/0","index":24880,"sub":1,"name":"Process value (REAL32)",)j"
            R"j("type":"REAL32","value":2.5020000000000002,"unit":"bar","raw":10008.0,"counts":10008.0})j"
            "\n");
}

TEST(CtlOutput, ActingVerbsAnswerWithJson) {
  std::ostringstream text, json;
  Printer(text, false).acted({"vcan0/dps/0", true});
  Printer(text, false).acted({"vcan0/dps/0", true, 7});
  EXPECT_EQ(text.str(), "7\n");  // nothing but a fault's id, as Unix tools do
  Printer(json, true).acted({"vcan0/dps/0", true});
  Printer(json, true).acted({"vcan0/dps/0", true, 7});
  Printer(json, true).done();
  EXPECT_EQ(json.str(), R"j({"node":"vcan0/dps/0","ok":true})j"
                        "\n"
                        R"j({"node":"vcan0/dps/0","ok":true,"id":7})j"
                        "\n"
                        R"j({"ok":true})j"
                        "\n");
}

TEST(CtlOutput, OneVocabularyAcrossVerbs) {
  NodeStatus s;
  s.path = "/io/cansim/Cansimd1/node/vcan0/dps/0";
  s.key = "vcan0/dps/0";
  s.name = "dps";
  s.interface = "vcan0";
  s.node_id = 0x7F;
  s.nmt_state = "operational";
  s.powered = s.on_bus = true;
  s.pressure = {3.5, 3.25, "bar", 0};
  s.faults = {{2, "open", true}};
  s.last_emcy = {1500000, 0x2201, 0x81, {1, 2, 3, 4, 5}};
  std::ostringstream status;
  Printer(status, true).status(s);
  EXPECT_EQ(status.str(),
            R"j({"node":"vcan0/dps/0","name":"dps","entry_index":0,"interface":"vcan0","node_id":127,"profile":"",)j"
            R"j("personality":"","nmt_state":"operational","powered":true,"on_bus":true,)j"
            R"j("pressure":{"value":3.25,"true_value":3.5,"unit":"bar","status":0,"counts":null},"temperature":null,)j"
            R"j("overrides":[],"faults":[{"id":2,"kind":"open","active":true}],"emcy_count":0,)j"
            R"j("last_emcy":{"time":1.5,"code":8705,"register":129,"vendor":"0102030405"},"recording":null,)j"
            R"j("path":"/io/cansim/Cansimd1/node/vcan0/dps/0"})j"
            "\n");
  // watch: the same names (time, node, kind), the signal's values as fields.
  Event e{std::int64_t(2500000),
          "vcan0/dps/0",
          "NmtStateChanged",
          {{"old", Value(std::string("pre-operational"))}, {"new", Value(std::string("operational"))}}};
  std::ostringstream watch;
  Printer(watch, true).event(e);
  EXPECT_EQ(watch.str(), R"j({"time":2.5,"node":"vcan0/dps/0","kind":"NmtStateChanged","fields":[)j"
                         R"j({"name":"old","value":"pre-operational"},{"name":"new","value":"operational"}]})j"
                         "\n");
  Event fleet{std::nullopt, "fleet", "NodeAdded", {}};
  std::ostringstream fleet_json;
  Printer(fleet_json, true).event(fleet);
  EXPECT_EQ(fleet_json.str(), R"j({"time":null,"node":null,"kind":"NodeAdded","fields":[]})j"
                              "\n");
  // faults: seconds, null for "until cancelled" and "once".
  std::ostringstream faults;
  Printer(faults, true).faults({{3, "drift", "pressure", true, 1000000, -1, 0, 1}});
  EXPECT_EQ(faults.str(), R"j([{"id":3,"kind":"drift","channel":"pressure","active":true,"start":1.0,)j"
                          R"j("duration":null,"period":null,"count":1}])j"
                          "\n");
  std::ostringstream time;
  Printer(time, true).time(12345678);
  EXPECT_EQ(time.str(), R"j({"time":12.345678})j"
                        "\n");
}

TEST(CtlValues, MeasuresReadWellAtEveryMagnitude) {
  EXPECT_EQ(format_measure(9990440.0), "9 990 440");  // a P92C's Pa, not 9.99044e+06
  EXPECT_EQ(format_measure(-12345.5), "-12 345.5");
  EXPECT_EQ(format_measure(1013.25), "1013.25");  // four digits stay together
  EXPECT_EQ(format_measure(3.5), "3.5");
  EXPECT_EQ(format_measure(double(2.4996371f)), "2.4996371");  // a REAL32: the float's own digits
  EXPECT_EQ(format_measure(2.49963710000001), "2.49964");      // computed: six significant digits
  EXPECT_EQ(format_measure(0.000123456789), "0.000123457");
  EXPECT_EQ(format_measure(0.0), "0");
  EXPECT_EQ(format_measure(NAN), "-");
  EXPECT_EQ(format_number(1e6), "1000000");
  EXPECT_EQ(format_number(0.1), "0.1");
}

TEST(CtlArgs, UsageListsEveryVerb) {
  std::string usage = usage_text();
  for (const char* verb : {"list",    "status", "set",         "hold",   "model",  "restore-model", "override", "fault",
                           "faults",  "cancel", "power-cycle", "nmt",    "read",   "write",         "record",   "store",
                           "restore", "watch",  "add",         "remove", "reload", "time",          "stats"})
    EXPECT_NE(usage.find(std::string("\n  ") + verb + " "), std::string::npos) << verb;
}

// ---------------------------------------------------------------- values

TEST(CtlValues, WriteValueTypedByItsLook) {
  EXPECT_EQ(typed_value("1000"), Value(std::int64_t(1000)));
  EXPECT_EQ(typed_value("-5"), Value(std::int64_t(-5)));
  EXPECT_EQ(typed_value("+7"), Value(std::int64_t(7)));
  EXPECT_EQ(typed_value("18446744073709551615"), Value(std::uint64_t(UINT64_MAX)));
  EXPECT_EQ(typed_value("0x3E8"), Value(std::uint64_t(1000)));
  EXPECT_EQ(typed_value("1.5"), Value(1.5));
  EXPECT_EQ(typed_value("-.25"), Value(-0.25));
  EXPECT_EQ(typed_value("2e3"), Value(2000.0));
  EXPECT_EQ(typed_value("\"123\""), Value(std::string("123")));
  EXPECT_EQ(typed_value("hello world"), Value(std::string("hello world")));
  EXPECT_EQ(typed_value("nan"), Value(std::string("nan")));
  EXPECT_EQ(typed_value(""), Value(std::string("")));
  EXPECT_FALSE(typed_value("99999999999999999999"));  // beyond 64 bits
  EXPECT_FALSE(typed_value("1.2.3"));
  EXPECT_FALSE(typed_value("0xZZ"));
}

TEST(CtlValues, WriteValueOfAForcedType) {
  EXPECT_EQ(typed_value("255", "u8"), Value(std::uint8_t(255)));
  EXPECT_FALSE(typed_value("256", "u8"));
  EXPECT_FALSE(typed_value("-1", "u8"));
  EXPECT_EQ(typed_value("0xffff", "u16"), Value(std::uint16_t(0xFFFF)));
  EXPECT_EQ(typed_value("4294967295", "u32"), Value(std::uint32_t(UINT32_MAX)));
  EXPECT_EQ(typed_value("0xffffffffffffffff", "u64"), Value(std::uint64_t(UINT64_MAX)));
  EXPECT_EQ(typed_value("-128", "i8"), Value(std::int16_t(-128)));  // D-Bus has no signed byte
  EXPECT_FALSE(typed_value("128", "i8"));
  EXPECT_EQ(typed_value("-32768", "i16"), Value(std::int16_t(-32768)));
  EXPECT_EQ(typed_value("-2147483648", "i32"), Value(std::int32_t(INT32_MIN)));
  EXPECT_EQ(typed_value("-9223372036854775808", "i64"), Value(std::int64_t(INT64_MIN)));
  EXPECT_FALSE(typed_value("9223372036854775808", "i64"));
  EXPECT_EQ(typed_value("3", "f32"), Value(3.0));
  EXPECT_EQ(typed_value("-1.5", "f64"), Value(-1.5));
  EXPECT_FALSE(typed_value("x", "f64"));
  EXPECT_EQ(typed_value("true", "bool"), Value(true));
  EXPECT_EQ(typed_value("0", "bool"), Value(false));
  EXPECT_FALSE(typed_value("2", "bool"));
  EXPECT_EQ(typed_value("\"q\"", "str"), Value(std::string("\"q\"")));
  EXPECT_EQ(typed_value("01:02:ff", "bytes"), Value(Bytes{1, 2, 0xFF}));
  EXPECT_FALSE(typed_value("1", "u12"));
}

TEST(CtlValues, Signatures) {
  EXPECT_STREQ(signature(Value(true)), "b");
  EXPECT_STREQ(signature(Value(std::int16_t(1))), "n");
  EXPECT_STREQ(signature(Value(std::uint64_t(1))), "t");
  EXPECT_STREQ(signature(Value(Bytes{})), "ay");
}

TEST(CtlValues, Bytes) {
  EXPECT_EQ(parse_bytes("0102ff"), (Bytes{1, 2, 0xFF}));
  EXPECT_EQ(parse_bytes("0x01 02 FF"), (Bytes{1, 2, 0xFF}));
  EXPECT_EQ(parse_bytes("01-02"), (Bytes{1, 2}));
  EXPECT_EQ(parse_bytes(""), Bytes{});
  EXPECT_FALSE(parse_bytes("012"));
  EXPECT_FALSE(parse_bytes("0 12"));
  EXPECT_FALSE(parse_bytes("gg"));
}

TEST(CtlValues, ObjectAddresses) {
  EXPECT_EQ(parse_object_address("0x6130:1"), (ObjectAddress{0x6130, 1}));
  EXPECT_EQ(parse_object_address("0x1017"), (ObjectAddress{0x1017, 0}));
  EXPECT_EQ(parse_object_address("1017h"), (ObjectAddress{0x1017, 0}));
  EXPECT_EQ(parse_object_address("6130h:0x2"), (ObjectAddress{0x6130, 2}));
  EXPECT_EQ(parse_object_address("4119:255"), (ObjectAddress{4119, 255}));
  EXPECT_EQ(parse_object_address("0xFFFF"), (ObjectAddress{0xFFFF, 0}));
  EXPECT_FALSE(parse_object_address("0x10000"));
  EXPECT_FALSE(parse_object_address("0x1017:256"));
  EXPECT_FALSE(parse_object_address("0x1017:"));
  EXPECT_FALSE(parse_object_address(":1"));
  EXPECT_FALSE(parse_object_address("-1"));
  EXPECT_FALSE(parse_object_address("0x"));
  EXPECT_FALSE(parse_object_address("h"));
}

TEST(CtlValues, Durations) {
  EXPECT_EQ(normalise_duration("500ms"), "500 ms");
  EXPECT_EQ(normalise_duration("2 s"), "2 s");
  EXPECT_EQ(normalise_duration("1.5s"), "1.5 s");
  EXPECT_EQ(normalise_duration("10 min"), "10 min");
  EXPECT_EQ(normalise_duration(" 3  h "), "3 h");
  EXPECT_EQ(normalise_duration("1.5"), "1.5 s");
  EXPECT_EQ(normalise_duration("250us"), "250 us");
  EXPECT_EQ(normalise_duration("1e3ms"), "1e3 ms");
  EXPECT_FALSE(normalise_duration("-1s"));
  EXPECT_FALSE(normalise_duration("1 day"));
  EXPECT_FALSE(normalise_duration("ms"));
  EXPECT_FALSE(normalise_duration(""));
  EXPECT_EQ(parse_duration_seconds("500ms"), 0.5);
  EXPECT_EQ(parse_duration_seconds("10 min"), 600.0);
  EXPECT_EQ(parse_duration_seconds("2"), 2.0);
  EXPECT_EQ(parse_duration_seconds("1h"), 3600.0);
  EXPECT_FALSE(parse_duration_seconds("soon"));
}

TEST(CtlValues, Printing) {
  EXPECT_EQ(format_value(Value(std::uint16_t(1000))), "1000 (0x3e8)");
  EXPECT_EQ(format_value(Value(std::int16_t(-5))), "-5 (0xfffb)");
  EXPECT_EQ(format_value(Value(std::uint8_t(16)), IntegerStyle::kHex), "0x10");
  EXPECT_EQ(format_value(Value(std::int64_t(7)), IntegerStyle::kDecimal), "7");
  EXPECT_EQ(format_value(Value(true)), "true");
  EXPECT_EQ(format_value(Value(std::string("DPS 1"))), "DPS 1");
  EXPECT_EQ(format_value(Value(Bytes{0x00, 0xAB, 0x10})), "00 ab 10");
  EXPECT_EQ(format_value(Value(double(0.1f))), "0.1");  // a REAL32 read back
  EXPECT_EQ(format_value(Value(0.1)), "0.1");
  EXPECT_EQ(format_value(Value(1.0 / 3)), "0.3333333333333333");
  EXPECT_EQ(format_seconds(12345678), "12.345678");
  EXPECT_EQ(format_seconds(5), "0.000005");
  EXPECT_EQ(format_seconds(-1500000), "-1.500000");
}

// ---------------------------------------------------------------- JSON

TEST(CtlJson, NumbersStringsAndBytes) {
  EXPECT_EQ(json_number(double(0.1f)).dump(), "0.1");  // a REAL32's own digits
  EXPECT_EQ(json_number(0.1).dump(), "0.1");
  EXPECT_EQ(json_number(NAN).dump(), "null");
  EXPECT_EQ(json_number(INFINITY).dump(), "null");
  EXPECT_EQ(json_value(Value(Bytes{1, 0xAB})).dump(), "\"01ab\"");
  EXPECT_EQ(json_value(Value(std::string("a\"b\\c\nd"))).dump(), R"("a\"b\\c\nd")");
  EXPECT_EQ(json_seconds(-1).dump(), "null");
  EXPECT_EQ(json_seconds(1500000).dump(), "1.5");
  // Bytes that are not UTF-8 are replaced, not thrown.
  std::ostringstream out;
  print_json(out, Json{{"name", std::string("\xff")}});
  EXPECT_EQ(out.str(), "{\"name\":\"\xEF\xBF\xBD\"}\n");
}

TEST(CtlJson, ReadValue) {
  std::ostringstream out;
  Printer(out, true).value("vcan0/dps/0", {0x6130, 1}, Value(std::uint32_t(1000)));
  Printer(out, true).value("vcan0/dps/0", {0x1008, 0}, Value(std::string("DPS \"x\"")));
  Printer(out, true).value("vcan0/dps/0", {0x2000, 0}, Value(Bytes{1, 0xAB}));
  EXPECT_EQ(out.str(),
            R"({"node":"vcan0/dps/0","index":24880,"sub":1,"name":null,"type":null,"value":1000,"unit":null,)"
            R"("raw":1000,"counts":null})"
            "\n"
            R"({"node":"vcan0/dps/0","index":4104,"sub":0,"name":null,"type":null,"value":"DPS \"x\"","unit":null,)"
            R"("raw":"DPS \"x\"","counts":null})"
            "\n"
            R"({"node":"vcan0/dps/0","index":8192,"sub":0,"name":null,"type":null,"value":"01ab","unit":null,)"
            R"("raw":"01ab","counts":null})"
            "\n");
}

// ---------------------------------------------------------------- output

TEST(CtlOutput, NodeTable) {
  std::ostringstream out;
  Printer(out, false)
      .nodes({{"/p", "vcan0/generic/0", "generic", "vcan0", 0x10, "generic-404", "generic", "operational"}});
  EXPECT_EQ(out.str(),
            "KEY              NAME     INTERFACE  ID    PROFILE      PERSONALITY  NMT\n"
            "vcan0/generic/0  generic  vcan0      0x10  generic-404  generic      operational\n");
}

TEST(CtlOutput, Status) {
  NodeStatus s;
  s.key = "vcan0/dps/0", s.name = "dps", s.node_id = 0x22, s.nmt_state = "stopped", s.powered = true;
  s.pressure = {5.0, 5.01, "bar", 0};
  s.faults = {{1, "drift", true}, {2, "noise", false}};
  s.emcy_count = 2;
  s.last_emcy = {1500000, 0x5000, 0x81, {0, 1, 2, 3, 4}};
  std::ostringstream out;
  Printer(out, false).status(s);
  std::string text = out.str();
  EXPECT_TRUE(text.starts_with("vcan0/dps/0\n")) << text;
  EXPECT_NE(text.find("  node-ID      0x22 (34)\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  NMT state    stopped\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  power        on, off the bus\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  pressure     5.01 bar reported, 5 bar true, status 0x00\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  temperature  none\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  faults       1 drift (active), 2 noise\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  EMCY         2 sent, last at 1.500000 s: code 0x5000, register 0x81, vendor 00 01 02 03 04"),
            std::string::npos)
      << text;

  // A device in counts: its PV beside what it means.
  NodeStatus smc = s;
  smc.pressure = {2.5, 2.50175, "bar", 0, 10007.0};
  std::ostringstream smc_text;
  Printer(smc_text, false).status(smc);
  EXPECT_NE(smc_text.str().find("  pressure     2.50175 bar (10 007 counts) reported, 2.5 bar true, status 0x00\n"),
            std::string::npos)
      << smc_text.str();

  std::ostringstream json;
  Printer(json, true).status(s);
  EXPECT_NE(json.str().find(R"("pressure":{"value":5.01,"true_value":5.0,"unit":"bar","status":0,"counts":null})"),
            std::string::npos)
      << json.str();
  EXPECT_NE(json.str().find(R"("temperature":null)"), std::string::npos) << json.str();
  EXPECT_NE(json.str().find(R"("last_emcy":{"time":1.5,"code":20480,"register":129,"vendor":"0001020304"})"),
            std::string::npos)
      << json.str();
}

TEST(CtlOutput, EventLines) {
  Event e{12345678,
          "vcan0/dps/0",
          "ObjectWritten",
          {{"index", Value(std::uint16_t(0x6131)), IntegerStyle::kHex},
           {"sub", Value(std::uint8_t(1))},
           {"value", Value(std::string("a b"))},
           {"via", Value(std::string("sdo"))}}};
  EXPECT_EQ(format_event(e), "   12.345678 vcan0/dps/0 ObjectWritten index=0x6131 sub=1 value=\"a b\" via=sdo");
  std::ostringstream json;
  Printer(json, true).event(e);
  EXPECT_EQ(json.str(), R"({"time":12.345678,"node":"vcan0/dps/0","kind":"ObjectWritten","fields":[)"
                        R"({"name":"index","value":24881},{"name":"sub","value":1},{"name":"value","value":"a b"},)"
                        R"({"name":"via","value":"sdo"}]})"
                        "\n");
  EXPECT_EQ(format_event({std::nullopt, "fleet", "NodeAdded", {}}), "           - fleet NodeAdded");
}

TEST(CtlOutput, FaultsAndStats) {
  std::ostringstream out;
  Printer(out, false)
      .faults(
          {{1, "drift", "pressure", true, 10000000, -1, 0, 0}, {2, "noise", "", false, 500000, 250000, 2000000, 3}});
  EXPECT_EQ(out.str(),
            "ID  KIND   CHANNEL   ACTIVE  START      DURATION         PERIOD  COUNT\n"
            "1   drift  pressure  yes     10.000000  until cancelled  -       0\n"
            "2   noise  -         no      0.500000   0.25 s           2 s     3\n");
  std::ostringstream stats;
  Printer(stats, false).stats({{"vcan0", false, 250, 1,    2,    3,     4,     0.123, 0.0,  "timed", "error-passive",
                                0.9,     0.85,  0.8, 0.75, 1200, 15000, 20000, 300,   2500, 3,       1024,
                                7}});
  EXPECT_EQ(stats.str(),
            "INTERFACE  UP  KBIT/S  IN  OUT  DROPPED  OFFLINE\n"
            "vcan0      no  250     1   2    3        4\n"
            "\n"
            "INTERFACE  MODEL  STATE          CARRIED 1S  10S    OFFERED 1S  10S    DELAY P50  P99      MAX      "
            "SLIP P99  MAX     QUEUED  LOST\n"
            "vcan0      timed  error-passive  80.0%       75.0%  90.0%       85.0%  1.2 ms     15.0 ms  20.0 ms  "
            "0.3 ms    2.5 ms  3/1024  7\n");
}

TEST(CtlOutput, SmallReplies) {
  std::ostringstream text, json;
  Printer(text, false).acted({"vcan0/dps/0", true, 3});
  Printer(text, false).time(1500000);
  Printer(text, false).added({{kNodePathPrefix, "vcan0/extra/0"}});
  Printer(text, false).value("vcan0/dps/0", {0x1017, 0}, Value(std::uint16_t(1000)));
  EXPECT_EQ(text.str(), "3\n1.500000 s\nvcan0/extra/0\n1000 (0x3e8)\n");
  Printer(json, true).acted({"vcan0/dps/0", true, 3});
  Printer(json, true).time(1500000);
  Printer(json, true).added({{"/p", "vcan0/extra/0"}});
  EXPECT_EQ(json.str(),
            "{\"node\":\"vcan0/dps/0\",\"ok\":true,\"id\":3}\n{\"time\":1.5}\n"
            "[{\"node\":\"vcan0/extra/0\",\"path\":\"/p\"}]\n");
}

// ---------------------------------------------------------------- endpoints

TEST(CtlEndpoint, OptionsWin) {
  Environment env{"/env/control", "/run/user/1000", 1000};
  auto everything = [](const std::string&) { return true; };
  GlobalOptions o;
  o.bus = BusKind::kSocket;
  o.socket = "/x/control";
  EXPECT_EQ(choose_endpoint(o, env, everything), (Endpoint{BusKind::kSocket, "/x/control"}));
  o.bus = BusKind::kSystem;
  EXPECT_EQ(choose_endpoint(o, env, everything), (Endpoint{BusKind::kSystem, ""}));
  o.bus = BusKind::kUser;
  EXPECT_EQ(choose_endpoint(o, env, everything), (Endpoint{BusKind::kUser, ""}));
}

TEST(CtlEndpoint, DefaultSocketThenBus) {
  GlobalOptions o;
  auto nothing = [](const std::string&) { return false; };
  EXPECT_EQ(choose_endpoint(o, {"/env/control", "", 1000}, nothing), (Endpoint{BusKind::kSocket, "/env/control"}));

  Environment user{"", "/run/user/1000", 1000};
  EXPECT_EQ(default_socket_paths(user),
            (std::vector<std::string>{"/run/user/1000/cansimd/control", "/run/cansimd/control",
                                      "/tmp/cansimd-1000/control"}));
  EXPECT_EQ(default_socket_paths({"", "", 0}),
            (std::vector<std::string>{"/run/cansimd/control", "/tmp/cansimd-0/control"}));
  auto only = [](std::string path) { return [path](const std::string& p) { return p == path; }; };
  EXPECT_EQ(choose_endpoint(o, user, only("/run/cansimd/control")),
            (Endpoint{BusKind::kSocket, "/run/cansimd/control"}));
  EXPECT_EQ(choose_endpoint(o, user, only("/tmp/cansimd-1000/control")),
            (Endpoint{BusKind::kSocket, "/tmp/cansimd-1000/control"}));
  EXPECT_EQ(choose_endpoint(o, user, nothing), (Endpoint{BusKind::kUser, ""}));
  EXPECT_EQ(choose_endpoint(o, {"", "", 0}, nothing), (Endpoint{BusKind::kSystem, ""}));
}

TEST(CtlEndpoint, SocketAddressIsEscaped) {
  EXPECT_EQ(socket_address("/run/cansimd/control"), "unix:path=/run/cansimd/control");
  EXPECT_EQ(socket_address("/tmp/a b,c=d;%"), "unix:path=/tmp/a%20b%2cc%3dd%3b%25");
}

TEST(CtlEndpoint, NodeKeyOfPath) {
  EXPECT_EQ(node_key_of_path("/io/cansim/Cansimd1/node/vcan0/generic_2d404/0"), "vcan0/generic-404/0");
  EXPECT_EQ(node_key_of_path("/io/cansim/Cansimd1"), "");
  EXPECT_EQ(node_key_of_path("/elsewhere/a/b/c"), "");
}

// ---------------------------------------------------------------- decoding

// Messages built on an unconnected end of a socketpair, sealed and rewound as
// if they had been received.
class MessageFactory {
 public:
  MessageFactory() {
    EXPECT_EQ(socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds_), 0);
    EXPECT_GE(sd_bus_new(&bus_), 0);
    EXPECT_GE(sd_bus_set_fd(bus_, fds_[0], fds_[0]), 0);
    EXPECT_GE(sd_bus_start(bus_), 0);
  }
  ~MessageFactory() {
    sd_bus_close_unref(bus_);
    close(fds_[1]);
  }

  MessagePtr signal(const char* path, const char* interface, const char* member) {
    sd_bus_message* m = nullptr;
    EXPECT_GE(sd_bus_message_new_signal(bus_, &m, path, interface, member), 0);
    return MessagePtr(m);
  }

  static sd_bus_message* received(const MessagePtr& m) {
    EXPECT_GE(sd_bus_message_seal(m.get(), 1, 0), 0);
    EXPECT_GE(sd_bus_message_rewind(m.get(), 1), 0);
    return m.get();
  }

 private:
  int fds_[2] = {-1, -1};
  sd_bus* bus_ = nullptr;
};

constexpr const char* kNodePath = "/io/cansim/Cansimd1/node/vcan0/dps/_30";

TEST(CtlDecode, TimedNodeSignal) {
  MessageFactory f;
  MessagePtr m = f.signal(kNodePath, kNodeInterface, "ObjectWritten");
  ASSERT_GE(sd_bus_message_append(m.get(), "xqyvs", std::int64_t(2500000), std::uint16_t(0x6131), std::uint8_t(1), "u",
                                  std::uint32_t(7), "sdo"),
            0);
  Event e = read_event(MessageFactory::received(m));
  EXPECT_EQ(e.time_us, 2500000);
  EXPECT_EQ(e.source, "vcan0/dps/0");
  EXPECT_EQ(format_event(e), "    2.500000 vcan0/dps/0 ObjectWritten index=0x6131 sub=1 value=7 via=sdo");
}

TEST(CtlDecode, FleetSignalHasNoTime) {
  MessageFactory f;
  MessagePtr m = f.signal(kFleetPath, kFleetInterface, "NodeRemoved");
  ASSERT_GE(sd_bus_message_append(m.get(), "os", kNodePath, "vcan0/dps/0"), 0);
  Event e = read_event(MessageFactory::received(m));
  EXPECT_FALSE(e.time_us);
  EXPECT_EQ(e.source, "fleet");
  ASSERT_EQ(e.fields.size(), 2u);
  EXPECT_EQ(e.fields[1].name, "key");
  EXPECT_EQ(e.fields[1].value, Value(std::string("vcan0/dps/0")));
}

TEST(CtlDecode, PropertiesChanged) {
  MessageFactory f;
  MessagePtr m = f.signal(kNodePath, kPropertiesInterface, "PropertiesChanged");
  ASSERT_GE(sd_bus_message_append(m.get(), "sa{sv}as", kNodeInterface, 2, "Powered", "b", 0, "Faults", "a(usb)", 2,
                                  std::uint32_t(1), "drift", 1, std::uint32_t(2), "noise", 0, 1, "NodeId"),
            0);
  Event e = read_event(MessageFactory::received(m));
  EXPECT_EQ(e.name, "PropertiesChanged");
  e.time_us = 0;
  EXPECT_EQ(format_event(e),
            "    0.000000 vcan0/dps/0 PropertiesChanged Powered=false Faults=\"1 drift (active), 2 noise\" "
            "NodeId=(changed)");
  // JSON: the faults as a list, as status gives them.
  std::ostringstream json;
  Printer(json, true).event(e);
  EXPECT_NE(json.str().find(R"j({"name":"Faults","value":[{"id":1,"kind":"drift","active":true},)j"
                            R"j({"id":2,"kind":"noise","active":false}]})j"),
            std::string::npos)
      << json.str();
}

TEST(CtlDecode, NodeStatusSkipsUnknownProperties) {
  MessageFactory f;
  MessagePtr m = f.signal(kNodePath, kNodeInterface, "Test");
  ASSERT_GE(sd_bus_message_append(m.get(), "a{sv}", 7, "Key", "s", "vcan0/dps/0", "Future", "(ii)", 1, 2, "NodeId", "y",
                                  std::uint8_t(0x22), "Pressure", "(ddsy)", 1.0, 1.5, "bar", std::uint8_t(0), "Index",
                                  "s", "wrong type", "Overrides", "a(sds)", 1, "pressure", 3.0, "bar", "LastEmcy",
                                  "(xqyay)", std::int64_t(-1), std::uint16_t(0), std::uint8_t(0), 0),
            0);
  NodeStatus s = read_node_status(MessageFactory::received(m));
  EXPECT_EQ(s.key, "vcan0/dps/0");
  EXPECT_EQ(s.node_id, 0x22);
  EXPECT_EQ(s.pressure.reported, 1.5);
  EXPECT_EQ(s.pressure.unit, "bar");
  EXPECT_EQ(s.index, 0u);
  ASSERT_EQ(s.overrides.size(), 1u);
  EXPECT_EQ(s.overrides[0].value, 3.0);
  EXPECT_EQ(s.last_emcy.time_us, -1);
}

TEST(CtlDecode, ReadValues) {
  MessageFactory f;
  MessagePtr m = f.signal(kNodePath, kNodeInterface, "Test");
  const std::uint8_t bytes[] = {1, 2, 3};
  ASSERT_GE(sd_bus_message_open_container(m.get(), 'v', "ay"), 0);
  ASSERT_GE(sd_bus_message_append_array(m.get(), 'y', bytes, sizeof bytes), 0);
  ASSERT_GE(sd_bus_message_close_container(m.get()), 0);
  ASSERT_GE(sd_bus_message_append(m.get(), "vvn", "b", 1, "x", std::int64_t(-7), std::int16_t(-3)), 0);
  sd_bus_message* r = MessageFactory::received(m);
  EXPECT_EQ(read_value(r), Value(Bytes{1, 2, 3}));
  EXPECT_EQ(read_value(r), Value(true));
  EXPECT_EQ(read_int64(r), -7);
  EXPECT_EQ(read_value(r), Value(std::int16_t(-3)));
  EXPECT_THROW(read_value(r), Failure);  // nothing left
}

}  // namespace
}  // namespace cansim::ctl
