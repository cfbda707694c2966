// How long one control call holds the loop at each bound of
// config/limits.hpp (README "Limits"), and what the calls the bounds refuse
// cost. Each call goes over a real sd-bus peer connection (in process: the
// tests' BusPair) to a 100-node fake-clock fleet built as the daemon builds
// it (test::ControlFleet). The figure is the CPU time the server end spent
// in sd_bus_process() for the call (reading and checking the message, the
// method, the answer): what the daemon's loop spends on it, median and
// maximum over REPS runs.
//
//   ./build/bench/limits_bench [REPS=20] [FILTER]   (FILTER: only the calls whose line contains it)
//
// Prints figures, asserts nothing but that each call got the answer it should.
#include <systemd/sd-bus.h>

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "config/limits.hpp"
#include "support/control_fleet.hpp"

using namespace cansim;

namespace {

constexpr const char* kFleet = R"(
interfaces: {vcan0: {bit_rate: 1000}}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 1, count: 100, name: generic}
)";

struct Bench {
  test::ControlFleet fleet{kFleet};
  test::BusPair bus{fleet.service()};
  std::string node = control::node_path(*fleet.find("vcan0/generic/0"));
  int reps = 20;
  std::string filter;

  // Times `append` + the call `reps` times; `expect`: "" (success) or the error name.
  void run(const char* what, const char* member, bool on_node, const std::function<void(sd_bus_message*)>& append,
           const std::string& expect, const std::function<void()>& after = {}) {
    if (std::string(what).find(filter) == std::string::npos) return;
    std::vector<double> ms;
    std::string got, message;
    for (int i = 0; i < reps; ++i) {
      sd_bus_message* m = on_node ? bus.node_call(node, member) : bus.fleet_call(member);
      append(m);
      const double t0 = bus.server_cpu_ms();
      sd_bus_message* r = bus.call(m, &got, &message);
      ms.push_back(bus.server_cpu_ms() - t0);
      if (r) got.clear(), sd_bus_message_unref(r);
      if (got != expect) {
        std::fprintf(stderr, "%s: expected %s, got %s: %s\n", what, expect.empty() ? "success" : expect.c_str(),
                     got.empty() ? "success" : got.c_str(), message.c_str());
        std::exit(1);
      }
      if (after) after();
    }
    std::sort(ms.begin(), ms.end());
    std::printf("  %-58s %8.2f %8.2f  %s\n", what, ms[ms.size() / 2], ms.back(),
                expect.empty() ? "ok" : expect.substr(expect.rfind('.') + 1).c_str());
  }
  void remove(const std::string& key) {
    sd_bus_message* m = bus.fleet_call("RemoveNode");
    sd_bus_message_append(m, "s", key.c_str());
    if (sd_bus_message* r = bus.call(m)) sd_bus_message_unref(r);
  }
};

std::string repeat(const std::string& piece, std::size_t bytes) {
  std::string out;
  while (out.size() + piece.size() <= bytes) out += piece;
  return out;
}

// A text of exactly `bytes` (the rest padded with a comment).
std::string padded(std::string text, std::size_t bytes) {
  if (text.size() + 2 < bytes) text += "\n#" + std::string(bytes - text.size() - 2, ' ');
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  Bench b;
  if (argc > 1) b.reps = std::max(1, std::atoi(argv[1]));
  if (argc > 2) b.filter = argv[2];
  const std::size_t text = limits::kYamlTextBytes;
  std::printf("limits_bench: one call's CPU time, ms (median, max of %d), 100-node fleet\n", b.reps);
  std::printf("  %-58s %8s %8s  %s\n", "call", "median", "max", "answer");

  auto params = [](std::size_t n) {
    return [n](sd_bus_message* m) {
      sd_bus_message_append(m, "s", "drift");
      sd_bus_message_open_container(m, 'a', "{ss}");
      for (std::size_t i = 0; i < n; ++i) {
        const std::string key = i < limits::kFaultParams ? "duration" : "k" + std::to_string(i);
        sd_bus_message_append(m, "{ss}", key.c_str(), "1 s");
      }
      sd_bus_message_close_container(m);
    };
  };
  b.run("ArmFault, 32 parameters (the bound)", "ArmFault", true, params(limits::kFaultParams), "");
  b.run("ArmFault, 50,000 parameters", "ArmFault", true, params(50'000), "io.cansim.Error.TooLarge");
  b.run("ArmFault, a value of 256 bytes of '['", "ArmFault", true, [](sd_bus_message* m) {
    sd_bus_message_append(m, "s", "stuck");
    sd_bus_message_append(m, "a{ss}", 1, "value", std::string(limits::kFaultValueBytes, '[').c_str());
  }, "io.cansim.Error.TooLarge");

  auto model = [](std::string yaml) {
    return [yaml](sd_bus_message* m) { sd_bus_message_append(m, "ss", "pressure", yaml.c_str()); };
  };
  std::string table = "table: {interpolation: linear, points: [";
  for (int i = 0; table.size() + 40 < text; ++i) table += "[" + std::to_string(i) + " s, " + std::to_string(i % 9) + " bar], ";
  table += "[1e6 s, 1 bar]]}";
  b.run("SetModel, a 16 KiB table (the bound)", "SetModel", true, model(padded(table, text)), "");
  b.run("SetModel, 4 MiB of '['", "SetModel", true, model(std::string(4 << 20, '[')), "io.cansim.Error.TooLarge");
  for (std::size_t bytes : {std::size_t(64) << 10, limits::kTableFileBytes}) {
    const std::string csv = "/tmp/limits_bench_" + std::to_string(getpid()) + ".csv";
    {
      std::ofstream out(csv);
      std::size_t written = 0;
      for (int i = 0; written + 32 < bytes; ++i) {
        const std::string line = std::to_string(i) + "," + std::to_string(i % 9) + "\n";
        out << line;
        written += line.size();
      }
    }
    const std::string label = "SetModel, a CSV table of " + std::to_string(bytes >> 10) + " KiB" +
                              (bytes == limits::kTableFileBytes ? " (the bound)" : "");
    b.run(label.c_str(), "SetModel", true, model("table: {csv: " + csv + ", value_unit: bar}"), "");
    std::remove(csv.c_str());
  }
  std::string aliased = "- &t {table: {interpolation: linear, points: [";
  for (int i = 0; i < 300; ++i) aliased += "[" + std::to_string(i) + " s, " + std::to_string(i % 9) + " bar], ";
  aliased += "[1e6 s, 1 bar]]}}\n";
  const std::size_t head = aliased.size();
  while (aliased.size() + 5 <= text) aliased += "- *t\n";
  b.run(("SetModel, a table and " + std::to_string((aliased.size() - head) / 5) + " aliases of it").c_str(), "SetModel",
        true, model(aliased), "io.cansim.Error.TooLarge");
  b.run("SetModel, '[' nested 33 deep", "SetModel", true, model(std::string(33, '[') + std::string(33, ']')),
        "io.cansim.Error.TooLarge");

  auto add = [](std::string yaml) {
    return [yaml](sd_bus_message* m) { sd_bus_message_append(m, "s", yaml.c_str()); };
  };
  const std::string one = "{profile: generic-404, interface: vcan0, node_id: 120, name: extra}";
  b.run("AddNodes, one node (then RemoveNode)", "AddNodes", false, add(one), "", [&] { b.remove("vcan0/extra/0"); });
  const std::string unknown = "{profile: generic-404, interface: vcan0, node_id: 120, name: extra, vendor: {";
  b.run("AddNodes, 16 KiB vendor map of unknown keys", "AddNodes", false,
        add(unknown + repeat("k: 1, ", text - unknown.size() - 2) + "}}"), "io.cansim.Error.Config");
  const std::string known = "{profile: generic-404, interface: vcan0, node_id: 120, name: extra, vendor: {";
  b.run("AddNodes, 16 KiB vendor map of a known key", "AddNodes", false,
        add(known + repeat("cia404: {}, ", text - known.size() - 2) + "}}"), "", [&] { b.remove("vcan0/extra/0"); });
  std::string many = "nodes:\n";
  for (std::size_t i = 0; i < limits::kAddNodesEntries; ++i)
    many += "- {profile: generic-404, interface: vb" + std::to_string(i) + ", node_id: 1, count: " +
            std::to_string(limits::kAddNodesNodes / limits::kAddNodesEntries) + ", name: m}\n";
  b.run("AddNodes, 4 entries x 32 nodes (the bounds)", "AddNodes", false, add(many), "", [&] {
    for (std::size_t i = 0; i < limits::kAddNodesEntries; ++i)
      for (std::size_t k = 0; k < limits::kAddNodesNodes / limits::kAddNodesEntries; ++k)
        b.remove("vb" + std::to_string(i) + "/m/" + std::to_string(k));
  });
  // Every entry a variant (its own copy of the profile, parsed again with the override).
  std::string variants = "nodes:\n";
  const char* kProfiles[] = {"generic-404", "dps", "p92c", "gems9000", "smc", "cmp"};
  for (std::size_t i = 0; i < limits::kAddNodesEntries; ++i)
    variants += "- {profile: " + std::string(kProfiles[i % 6]) + ", interface: vv" + std::to_string(i) +
                ", node_id: 1, name: v, vendor: {serial_number_base: " + std::to_string(i) + "}}\n";
  b.run("AddNodes, 4 entries of 4 profiles, with vendor: (the bounds)", "AddNodes", false, add(variants), "", [&] {
    for (std::size_t i = 0; i < limits::kAddNodesEntries; ++i) b.remove("vv" + std::to_string(i) + "/v/0");
  });
  // One entry's text copied into every node of its `count:` group.
  std::string faults = "{profile: generic-404, interface: vf, node_id: 1, count: 127, name: f, faults: [";
  for (int i = 0; faults.size() + 50 < text; ++i) faults += "{kind: drift, drift: 1 bar, at: " + std::to_string(i) + " s}, ";
  faults += "{kind: open}]}";
  b.run("AddNodes, 127 nodes with 16 KiB of faults each", "AddNodes", false, add(faults), "", [&] {
    for (int k = 0; k < 127; ++k) b.remove("vf/f/" + std::to_string(k));
  });
  std::string physics = "{profile: generic-404, interface: vp, node_id: 1, count: 127, name: p, physics: {pressure: "
                        "{table: {interpolation: linear, points: [";
  for (int i = 0; physics.size() + 50 < text; ++i) physics += "[" + std::to_string(i) + " s, " + std::to_string(i % 9) + " bar], ";
  physics += "[1e6 s, 1 bar]]}}}}";
  b.run("AddNodes, 127 nodes with a 16 KiB table each", "AddNodes", false, add(physics), "", [&] {
    for (int k = 0; k < 127; ++k) b.remove("vp/p/" + std::to_string(k));
  });
  b.run("AddNodes, 4 MiB", "AddNodes", false, add(std::string(4 << 20, ' ')), "io.cansim.Error.TooLarge");
  b.run("AddNodes, 100 MiB (sd-bus takes up to 128 MiB)", "AddNodes", false, add(std::string(100 << 20, ' ')),
        "io.cansim.Error.TooLarge");
  b.run("AddNodes, 4 MiB of '['", "AddNodes", false, add(std::string(4 << 20, '[')), "io.cansim.Error.TooLarge");
  b.run("AddNodes, '- ' nested 40 deep", "AddNodes", false, add(repeat("- ", 80) + "x"), "io.cansim.Error.TooLarge");
  return 0;
}
