// How long one control call holds the loop at each bound of
// config/limits.hpp (docs/limits.md), and what the calls the bounds refuse
// cost. Each call goes over a real sd-bus peer connection (in process: the
// tests' BusPair) to a 100-node fake-clock fleet built as the daemon builds
// it (test::ControlFleet). The figure is the CPU time the server end spent
// in sd_bus_process() for the call (reading and checking the message, the
// method, the answer): what the daemon's loop spends on it, median and
// maximum over REPS runs; "held": the longest single sd_bus_process() of
// those runs (with the gate's pump before it): the longest the call held
// the loop at once. The server reads through the private socket's message
// gate (control/message_gate.hpp), as the daemon does; the rows "sd-bus reads
// it whole" go over a direct connection, as a bus connection is read.
//
//   ./build/bench/limits_bench [REPS=20] [FILTER]   (FILTER: only the calls whose line contains it)
//
// Then what AddNodes, RemoveNode and a reload of one changed entry cost the
// daemon itself (daemon::Daemon, started without its loop, the calls over a
// BusPair to its control service) at 100, 1,000 and 3,968 nodes (4,096 with an AddNodes of 128): each call
// must cost what its own nodes cost, whatever the fleet's size.
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

#include <spdlog/spdlog.h>

#include <filesystem>

#include "config/limits.hpp"
#include "daemon/daemon.hpp"
#include "support/control_fleet.hpp"

using namespace cansim;

namespace {

constexpr const char* kFleet = R"(
interfaces: {vcan0: {bit_rate: 1000}}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 1, count: 100, name: generic}
)";

struct Bench {
  Bench() { fleet.allow_folder("/tmp"); }  // its `csv:` tables
  test::ControlFleet fleet{kFleet};
  // As the daemon's private socket reads (through its gate); `direct`: as
  // sd-bus reads a connection itself (a bus connection; the socket before).
  test::BusPair gated{fleet.service(), test::BusPair::kGated};
  test::BusPair direct_bus{fleet.service()};
  bool direct = false;
  std::string node = control::node_path(*fleet.find("vcan0/generic/0"));
  int reps = 20;
  std::string filter;

  test::BusPair& via() { return direct ? direct_bus : gated; }

  // Times `append` + the call `reps` times; `expect`: "" (success) or the error name.
  void run(const char* what, const char* member, bool on_node, const std::function<void(sd_bus_message*)>& append,
           const std::string& expect, const std::function<void()>& after = {}) {
    if (std::string(what).find(filter) == std::string::npos) return;
    std::vector<double> ms, held;
    std::string got, message;
    test::BusPair& bus = via();
    for (int i = 0; i < reps; ++i) {
      sd_bus_message* m = on_node ? bus.node_call(node, member) : bus.fleet_call(member);
      append(m);
      const double t0 = bus.server_cpu_ms();
      bus.take_longest_serve_ms();
      sd_bus_message* r = bus.call(m, &got, &message);
      ms.push_back(bus.server_cpu_ms() - t0);
      held.push_back(bus.take_longest_serve_ms());
      if (r) got.clear(), sd_bus_message_unref(r);
      if (got != expect) {
        std::fprintf(stderr, "%s: expected %s, got %s: %s\n", what, expect.empty() ? "success" : expect.c_str(),
                     got.empty() ? "success" : got.c_str(), message.c_str());
        std::exit(1);
      }
      if (after) after();
    }
    std::sort(ms.begin(), ms.end());
    std::sort(held.begin(), held.end());
    std::printf("  %-58s %8.2f %8.2f %8.2f  %s\n", what, ms[ms.size() / 2], ms.back(), held.back(),
                expect.empty() ? "ok" : expect.substr(expect.rfind('.') + 1).c_str());
  }
  void remove(const std::string& key) {
    sd_bus_message* m = via().fleet_call("RemoveNode");
    sd_bus_message_append(m, "s", key.c_str());
    if (sd_bus_message* r = via().call(m)) sd_bus_message_unref(r);
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

// A fleet file of `nodes` generic-404 nodes, 127 per interface (vb0, vb1,
// ...); `serial` is entry 0's first serial number (a changed entry).
void write_fleet(const std::string& path, std::size_t nodes, int serial) {
  std::ofstream out(path);
  const std::string profile = std::string(CANSIM_SOURCE_DIR) + "/profiles/generic-404.yaml";
  out << "nodes:\n";
  for (std::size_t i = 0, bus = 0; i < nodes; i += 127, ++bus)
    out << "  - {profile: " << profile << ", interface: vb" << bus
        << ", node_id: 1, count: " << std::min<std::size_t>(127, nodes - i) << ", name: n" << bus
        << (bus == 0 ? ", serial: " + std::to_string(serial) : "") << "}\n";
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The daemon's own fleet calls at one fleet size.
void fleet_calls(std::size_t nodes, int reps, const std::string& folder) {
  const std::string file = folder + "/fleet.yaml";
  write_fleet(file, nodes, 1000);
  daemon::DaemonSettings settings;
  settings.state_dir = folder + "/state";
  settings.config_file = file;
  settings.control_socket = "none";
  settings.bus = control::BusChoice::kNone;
  settings.load = [file](config::ProfileStore* store) {
    config::ProfileSearch search = daemon::profile_search(file);
    search.store = store;
    return config::load_fleet(file, search);
  };
  daemon::Daemon d(settings);
  d.start();
  test::BusPair bus(*d.control());
  const std::string profile = std::string(CANSIM_SOURCE_DIR) + "/profiles/generic-404.yaml";
  const std::string one = "{profile: " + profile + ", interface: vx, node_id: 1, name: extra}";
  std::string four;  // AddNodes at its bound: 4 entries of 32 nodes
  for (int k = 0; k < 4; ++k)
    four += std::string(k ? ", " : "[") + "{profile: " + profile + ", interface: vy" + std::to_string(k) +
            ", node_id: 1, count: 32, name: q}";
  four += "]";
  std::vector<double> add, add_four, remove, remove_grown, remove_file, reload, mappings;
  auto timed = [&](sd_bus_message* m, const char* what) {
    const double t0 = bus.server_cpu_ms();
    std::string error, message;
    sd_bus_message* r = bus.call(m, &error, &message);
    if (!r) {
      std::fprintf(stderr, "%s at %zu nodes: %s: %s\n", what, nodes, error.c_str(), message.c_str());
      std::exit(1);
    }
    sd_bus_message_unref(r);
    for (auto& [name, signal] : bus.take_signals()) sd_bus_message_unref(signal);
    return bus.server_cpu_ms() - t0;
  };
  for (int i = 0; i < reps; ++i) {
    sd_bus_message* m = bus.fleet_call("AddNodes");
    sd_bus_message_append(m, "s", one.c_str());
    add.push_back(timed(m, "AddNodes"));
    m = bus.fleet_call("RemoveNode");
    sd_bus_message_append(m, "s", "vx/extra/0");
    remove.push_back(timed(m, "RemoveNode"));
    m = bus.fleet_call("AddNodes");
    sd_bus_message_append(m, "s", four.c_str());
    add_four.push_back(timed(m, "AddNodes"));
    for (int k = 0; k < 4 * 32; ++k) {
      m = bus.fleet_call("RemoveNode");
      sd_bus_message_append(m, "s", ("vy" + std::to_string(k / 32) + "/q/" + std::to_string(k % 32)).c_str());
      remove_grown.push_back(timed(m, "RemoveNode"));
    }
    m = bus.fleet_call("GetPdoMappings");
    sd_bus_message_append(m, "s", "vb0");
    mappings.push_back(timed(m, "GetPdoMappings"));
    m = bus.fleet_call("RemoveNode");  // a node of the file (back at the reload below)
    sd_bus_message_append(m, "s", ("vb0/n0/" + std::to_string(i % 100)).c_str());
    remove_file.push_back(timed(m, "RemoveNode"));
    write_fleet(file, nodes, 1000 + (i + 1) % 2);  // entry 0's serial numbers change: its nodes restart
    reload.push_back(timed(bus.fleet_call("Reload"), "Reload"));
  }
  const std::size_t changed = std::min<std::size_t>(127, nodes);
  auto row = [&](const std::string& what, const std::vector<double>& ms) {
    std::printf("  %-58s %8.2f %8.2f\n", (what + ", " + std::to_string(nodes) + " nodes").c_str(), median(ms),
                *std::max_element(ms.begin(), ms.end()));
  };
  row("AddNodes, one node", add);
  row("RemoveNode, that node", remove);
  row("AddNodes, 4 entries x 32 nodes (to " + std::to_string(nodes + 128) + ")", add_four);
  row("RemoveNode, each of those 128 (from " + std::to_string(nodes + 128) + ")", remove_grown);
  row("RemoveNode, a node of the file", remove_file);
  row("GetPdoMappings of a bus (" + std::to_string(std::min<std::size_t>(nodes, 127)) + " nodes)", mappings);
  row("Reload, one entry of " + std::to_string(changed) + " changed, one node back", reload);
}

}  // namespace

int main(int argc, char** argv) {
  Bench b;
  if (argc > 1) b.reps = std::max(1, std::atoi(argv[1]));
  if (argc > 2) b.filter = argv[2];
  const std::size_t text = limits::kYamlTextBytes;
  std::printf("limits_bench: one call's CPU time, ms (median, max of %d), 100-node fleet\n", b.reps);
  std::printf("  %-58s %8s %8s %8s  %s\n", "call", "median", "max", "held", "answer");

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
  b.run(
      "ArmFault, a value of 256 bytes of '['", "ArmFault", true,
      [](sd_bus_message* m) {
        sd_bus_message_append(m, "s", "stuck");
        sd_bus_message_append(m, "a{ss}", 1, "value", std::string(limits::kFaultValueBytes, '[').c_str());
      },
      "io.cansim.Error.TooLarge");

  auto model = [](std::string yaml) {
    return [yaml](sd_bus_message* m) { sd_bus_message_append(m, "ss", "pressure", yaml.c_str()); };
  };
  std::string table = "table: {interpolation: linear, points: [";
  for (int i = 0; table.size() + 40 < text; ++i)
    table += "[" + std::to_string(i) + " s, " + std::to_string(i % 9) + " bar], ";
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
    many += "- {profile: generic-404, interface: vb" + std::to_string(i) +
            ", node_id: 1, count: " + std::to_string(limits::kAddNodesNodes / limits::kAddNodesEntries) +
            ", name: m}\n";
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
  for (int i = 0; faults.size() + 50 < text; ++i)
    faults += "{kind: drift, drift: 1 bar, at: " + std::to_string(i) + " s}, ";
  faults += "{kind: open}]}";
  b.run("AddNodes, 127 nodes with 16 KiB of faults each", "AddNodes", false, add(faults), "", [&] {
    for (int k = 0; k < 127; ++k) b.remove("vf/f/" + std::to_string(k));
  });
  std::string physics =
      "{profile: generic-404, interface: vp, node_id: 1, count: 127, name: p, physics: {pressure: "
      "{table: {interpolation: linear, points: [";
  for (int i = 0; physics.size() + 50 < text; ++i)
    physics += "[" + std::to_string(i) + " s, " + std::to_string(i % 9) + " bar], ";
  physics += "[1e6 s, 1 bar]]}}}}";
  b.run("AddNodes, 127 nodes with a 16 KiB table each", "AddNodes", false, add(physics), "", [&] {
    for (int k = 0; k < 127; ++k) b.remove("vp/p/" + std::to_string(k));
  });
  b.run("AddNodes, 4 MiB", "AddNodes", false, add(std::string(4 << 20, ' ')), "io.cansim.Error.TooLarge");
  b.run("AddNodes, 100 MiB (the private socket's gate)", "AddNodes", false, add(std::string(100 << 20, ' ')),
        "io.cansim.Error.TooLarge");
  b.direct = true;
  b.run("AddNodes, 4 MiB (sd-bus reads it whole: a bus)", "AddNodes", false, add(std::string(4 << 20, ' ')),
        "io.cansim.Error.TooLarge");
  b.run("AddNodes, 100 MiB (sd-bus reads it whole: a bus)", "AddNodes", false, add(std::string(100 << 20, ' ')),
        "io.cansim.Error.TooLarge");
  b.direct = false;
  b.run("AddNodes, 4 MiB of '['", "AddNodes", false, add(std::string(4 << 20, '[')), "io.cansim.Error.TooLarge");
  b.run("AddNodes, '- ' nested 40 deep", "AddNodes", false, add(repeat("- ", 80) + "x"), "io.cansim.Error.TooLarge");

  if (!b.filter.empty() && std::string("daemon fleet calls").find(b.filter) == std::string::npos) return 0;
  spdlog::set_level(spdlog::level::off);
  const std::string folder = "/tmp/limits_bench_" + std::to_string(getpid());
  std::filesystem::create_directories(folder);
  std::printf("daemon fleet calls: one call's CPU time, ms (median, max of %d)\n", b.reps);
  // The largest: the 128 nodes of one AddNodes at its bound grow it to the fleet's bound.
  for (std::size_t nodes : {std::size_t(100), std::size_t(1000), limits::kFleetNodes - 128})
    fleet_calls(nodes, b.reps, folder);
  std::filesystem::remove_all(folder);
  return 0;
}
