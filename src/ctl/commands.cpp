#include "ctl/commands.hpp"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <fstream>
#include <sstream>

#include "ctl/client_loop.hpp"
#include "ctl/decode.hpp"
#include "ctl/capture_replay.hpp"
#include "ctl/monitor.hpp"
#include "ctl/plants.hpp"
#include "ctl/targets.hpp"
#include "ctl/top.hpp"

#ifndef CANSIM_VERSION
#define CANSIM_VERSION "unknown"
#endif

namespace cansim::ctl {

namespace {

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Failure("cannot read " + path + ": " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void write_text_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) throw Failure("cannot write " + path + ": " + std::strerror(errno));
}

std::vector<NodeRef> node_refs(const std::vector<std::string>& paths) {
  std::vector<NodeRef> refs;
  for (const std::string& p : paths) refs.push_back({p, node_key_of_path(p)});
  return refs;
}

// The object's unit and scale (ListObjects) for `read`, and what its counts mean (ListCountScaling).
std::unique_ptr<ObjectInfo> meaning_of(Connection& c, const std::string& path, const ObjectAddress& a) {
  MessagePtr reply = c.call(path, kNodeInterface, "ListObjects");
  for (ObjectInfo& o : read_object_infos(reply.get())) {
    if (o.index != a.index || o.sub != a.sub) continue;
    auto meaning = std::make_unique<ObjectInfo>(std::move(o));
    if (meaning->unit == kCountsUnit)
      attach_count_scaling({meaning.get()}, read_count_scaling(c.call(path, kNodeInterface, "ListCountScaling").get()));
    return meaning;
  }
  return nullptr;
}

// What the daemon refuses as a bad command line rather than a refusal of the
// node: a word it does not know as a unit or a fault kind, an argument value
// it cannot read (exit status 2, the command's usage).
bool usage_level(const Request& r, const std::string& error_name) {
  return error_name == control::kErrorUnknownUnit || error_name == control::kErrorInvalidArgument ||
         (error_name == control::kErrorUnknownFault && r.call.method == "ArmFault");
}

// `path`: the node's object path, "" for a call that is about no node.
void print_reply(const Request& r, const std::string& path, sd_bus_message* reply, Printer& p,
                 const std::unique_ptr<ObjectInfo>& meaning) {
  switch (r.output) {
    case Output::kNodes: {
      std::vector<NodeRow> rows = read_node_rows(reply);
      std::sort(rows.begin(), rows.end(),
                [](const NodeRow& a, const NodeRow& b) { return natural_less(a.key, b.key); });
      return p.nodes(rows);
    }
    case Output::kStatus: {
      NodeStatus status = read_node_status(reply);
      status.path = path;
      return p.status(status);
    }
    case Output::kFaultId: return p.acted({node_key_of_path(path), true, read_uint32(reply)});
    case Output::kNothing: return path.empty() ? p.done() : p.acted({node_key_of_path(path), true});
    case Output::kFaults: return p.faults(read_fault_rows(reply));
    case Output::kValue: return p.value(node_key_of_path(path), r.object, read_value(reply), meaning.get());
    case Output::kAdded: return p.added(node_refs(read_object_paths(reply)));
    case Output::kTime: return p.time(read_int64(reply));
    case Output::kStats: return;  // run_request: three replies
    case Output::kDcf:
      return r.file.empty() ? p.document("dcf", read_text(reply)) : write_text_file(r.file, read_text(reply));
    case Output::kWatch:
    case Output::kCapture:
    case Output::kReplay:
    case Output::kMonitor:
    case Output::kTop:
    case Output::kPlant: return;
  }
}

// ---------------------------------------------------------------- watch

// Prints the signals of the fleet (or of one node) until SIGINT / SIGTERM.
int watch(Connection& connection, Printer& printer, const std::string& node_path) {
  ClientLoop loop(connection);
  std::string rule = "type='signal'," + (node_path.empty() ? "path_namespace='" + std::string(kFleetPath) + "'"
                                                           : "path='" + node_path + "'");
  loop.on_signals(rule, [&](sd_bus_message* m) {
    Event e = read_event(m);
    // Property changes and fleet signals carry no time: the daemon's clock now
    // is the time of the loop pass that sent them.
    if (!e.time_us) e.time_us = connection.simulated_time_us();
    printer.event(e);
  });
  connection.call(kFleetPath, kFleetInterface, "Subscribe");
  return loop.run("watch", printer.json());
}

// ---------------------------------------------------------------- groups

// An acting verb on each node of a group, one result per node; exit 1 when one refused.
int run_on_group(Connection& connection, const Request& request, const std::vector<NodeRow>& targets,
                 Printer& printer) {
  if (targets.empty()) throw Failure("no node matches '" + request.node + "'", control::kErrorUnknownNode);
  std::vector<GroupResult> results;
  std::size_t refused = 0;
  std::string usage_error;  // a usage-level refusal's D-Bus name: the whole line is wrong
  for (const NodeRow& n : targets) {
    GroupResult r{n.key};
    try {
      MessagePtr reply = connection.call(n.path, request.call.interface, request.call.method, request.call.args);
      if (request.output == Output::kFaultId) r.fault_id = read_uint32(reply.get());
      r.ok = true;
    } catch (const Failure& e) {
      r.error = e.what();
      ++refused;
      if (usage_level(request, e.name)) usage_error = e.name;
    }
    results.push_back(std::move(r));
  }
  printer.group(results);
  if (refused == 0) return 0;
  throw Failure(std::to_string(refused) + " of " + std::to_string(results.size()) + " nodes refused", usage_error);
}

// GetBusStatistics, then the BusLoad and BusStates properties of the same buses.
std::vector<BusStats> bus_statistics(Connection& connection, sd_bus_message* reply) {
  std::vector<BusStats> rows = read_bus_stats(reply);
  auto property = [&](const char* name) {
    return connection.call(kFleetPath, kPropertiesInterface, "Get",
                           {Value(std::string(kFleetInterface)), Value(std::string(name))});
  };
  read_bus_load(property("BusLoad").get(), rows);
  read_bus_states(property("BusStates").get(), rows);
  read_socketcand_buses(property("SocketcandBuses").get(), rows);
  return rows;
}

bool is_socket(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_socket(path, ec);
}

}  // namespace

int run_request(Connection& connection, const Request& request, Printer& printer) {
  if (request.output == Output::kMonitor)
    return run_monitor(connection, {request.interfaces, request.node, printer.json()}, printer.stream());
  if (request.output == Output::kCapture)
    return run_capture(connection, {request.interfaces[0], request.file}, std::cerr);
  if (request.output == Output::kReplay) {
    const ReplaySettings& r = request.replay;
    return run_replay(
        connection,
        {request.file, request.interfaces[0], r.loop, r.filtered, r.filter_id, r.filter_mask, r.speed, printer.json()},
        printer.stream());
  }
  if (request.output == Output::kTop)
    return run_top(connection, {request.pattern, request.once, printer.json()}, printer.stream());
  if (request.output == Output::kWatch) {
    std::string node_path = request.node.empty() ? "" : connection.node_path(request.node);
    return watch(connection, printer, node_path);
  }
  if (request.output == Output::kPlant) return run_plant(connection, request, printer.json(), printer.stream());
  if (const std::string plant = plant_target(request.node); !plant.empty() && request.call.target == Target::kNode) {
    // fault / faults / cancel on a plant: the same methods on its object.
    MessagePtr reply =
        connection.call(plant_path(connection, plant), kPlantInterface, request.call.method, request.call.args);
    if (request.output == Output::kFaults) {
      std::vector<FaultRow> rows = read_fault_rows(reply.get());
      for (FaultRow& f : rows) f.plant = true;
      printer.faults(rows, "TARGET");
    } else print_reply(request, "", reply.get(), printer, nullptr);
    return 0;
  }
  if (request.group) {
    MessagePtr list = connection.call(kFleetPath, kFleetInterface, "ListNodes");
    if (auto targets = group_targets(request.node, read_node_rows(list.get())))
      return run_on_group(connection, request, *targets, printer);
  }
  // The node a call is on, or about (remove NODE: a call of the fleet).
  const std::string node_path = request.node.empty() ? "" : connection.node_path(request.node);
  const std::string path = request.call.target == Target::kNode ? node_path : kFleetPath;
  std::vector<Arg> args = request.call.args;
  if (request.output == Output::kAdded) args = {Value(read_text_file(request.file))};
  MessagePtr reply = connection.call(path, request.call.interface, request.call.method, args);
  if (request.output == Output::kStats) {
    printer.stats(bus_statistics(connection, reply.get()));
    return 0;
  }
  std::unique_ptr<ObjectInfo> meaning;
  if (request.output == Output::kValue) meaning = meaning_of(connection, path, request.object);
  print_reply(request, node_path, reply.get(), printer, meaning);
  return 0;
}

int cansimctl_main(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  CommandLine line;
  try {
    line = parse_command_line(args);
  } catch (const UsageError& e) {
    const bool json = std::find(args.begin(), args.end(), "--json") != args.end();
    Printer::error(err, json, e.what(), "", 2);
    if (!json) err << '\n' << (e.verb.empty() ? usage_text() : verb_usage(e.verb));
    return 2;
  }
  if (line.global.help) {
    out << (line.help_verb.empty() ? usage_text() : verb_help(line.help_verb));
    return 0;
  }
  if (line.global.version) {
    out << "cansimctl " << CANSIM_VERSION << '\n';
    return 0;
  }
  try {
    Connection connection(choose_endpoint(line.global, process_environment(), is_socket), line.global.timeout_s);
    Printer printer(out, line.global.json);
    return run_request(connection, line.request, printer);
  } catch (const Failure& e) {
    out.flush();
    const int status = usage_level(line.request, e.name) ? 2 : 1;
    Printer::error(err, line.global.json, e.what(), e.name, status);
    if (status == 2 && !line.global.json) err << '\n' << verb_usage(line.request.verb);
    return status;
  }
}

}  // namespace cansim::ctl
