#include "ctl/commands.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "ctl/client_loop.hpp"
#include "ctl/decode.hpp"
#include "ctl/monitor.hpp"
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

void print_reply(const Request& r, const std::string& path, sd_bus_message* reply, Printer& p) {
  switch (r.output) {
    case Output::kNodes: return p.nodes(read_node_rows(reply));
    case Output::kStatus: {
      NodeStatus status = read_node_status(reply);
      status.path = path;
      return p.status(status);
    }
    case Output::kFaultId: return p.fault_id(read_uint32(reply));
    case Output::kFaults: return p.faults(read_fault_rows(reply));
    case Output::kValue: return p.value(r.object, read_value(reply));
    case Output::kAdded: return p.added(node_refs(read_object_paths(reply)));
    case Output::kTime: return p.time(read_int64(reply));
    case Output::kStats: return p.stats(read_bus_stats(reply));
    case Output::kDcf: return r.file.empty() ? p.document("dcf", read_text(reply)) : write_text_file(r.file, read_text(reply));
    case Output::kNothing:
    case Output::kWatch:
    case Output::kMonitor:
    case Output::kTop: return;
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
  return loop.run();
}

bool is_socket(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_socket(path, ec);
}

}  // namespace

int run_request(Connection& connection, const Request& request, Printer& printer) {
  if (request.output == Output::kMonitor)
    return run_monitor(connection, {request.interfaces, request.node, printer.json()}, printer.stream());
  if (request.output == Output::kTop)
    return run_top(connection, {request.pattern, request.once, printer.json()}, printer.stream());
  if (request.output == Output::kWatch) {
    std::string node_path = request.node.empty() ? "" : connection.node_path(request.node);
    return watch(connection, printer, node_path);
  }
  std::string path = request.call.target == Target::kNode ? connection.node_path(request.node) : kFleetPath;
  std::vector<Arg> args = request.call.args;
  if (request.output == Output::kAdded) args = {Value(read_text_file(request.file))};
  MessagePtr reply = connection.call(path, request.call.interface, request.call.method, args);
  print_reply(request, path, reply.get(), printer);
  return 0;
}

int cansimctl_main(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  CommandLine line;
  try {
    line = parse_command_line(args);
  } catch (const UsageError& e) {
    err << "cansimctl: " << e.what() << "\n\n" << usage_text();
    return 2;
  }
  if (line.global.help) {
    out << usage_text();
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
    err << "cansimctl: " << e.what() << '\n';
    return 1;
  }
}

}  // namespace cansim::ctl
