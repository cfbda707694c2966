#include "ctl/commands.hpp"

#include <systemd/sd-event.h>

#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "ctl/decode.hpp"

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
    case Output::kStats: return;  // run_request: three replies
    case Output::kDcf: return r.file.empty() ? p.document("dcf", read_text(reply)) : write_text_file(r.file, read_text(reply));
    case Output::kNothing:
    case Output::kWatch: return;
  }
}

// ---------------------------------------------------------------- watch

struct EventUnref {
  void operator()(sd_event* e) const { sd_event_unref(e); }
};
struct SlotUnref {
  void operator()(sd_bus_slot* s) const { sd_bus_slot_unref(s); }
};

// Prints the signals of the fleet (or of one node) until SIGINT / SIGTERM.
class Watch {
 public:
  Watch(Connection& connection, Printer& printer) : connection_(connection), printer_(printer) {}
  int run(const std::string& node_path);

 private:
  static int on_message(sd_bus_message* m, void* self, sd_bus_error*);
  static int on_stop(sd_event_source* source, const struct signalfd_siginfo*, void*);
  void print(sd_bus_message* m);
  void add_stop_signals();

  Connection& connection_;
  Printer& printer_;
  std::unique_ptr<sd_event, EventUnref> event_;
  std::string error_;
};

int Watch::on_stop(sd_event_source* source, const struct signalfd_siginfo*, void*) {
  return sd_event_exit(sd_event_source_get_event(source), 0);
}

int Watch::on_message(sd_bus_message* m, void* self, sd_bus_error*) {
  auto* watch = static_cast<Watch*>(self);
  try {
    watch->print(m);
  } catch (const std::exception& e) {
    watch->error_ = e.what();
    sd_event_exit(watch->event_.get(), 1);
  }
  return 0;
}

void Watch::print(sd_bus_message* m) {
  Event e = read_event(m);
  // Property changes and fleet signals carry no time: the daemon's clock now
  // is the time of the loop pass that sent them.
  if (!e.time_us) e.time_us = connection_.simulated_time_us();
  printer_.event(e);
}

// sd-event takes signals through a signalfd: they must be blocked first.
void Watch::add_stop_signals() {
  sigset_t set;
  sigemptyset(&set);
  for (int sig : {SIGINT, SIGTERM}) sigaddset(&set, sig);
  expect(sigprocmask(SIG_BLOCK, &set, nullptr) < 0 ? -errno : 0, "cannot block signals");
  for (int sig : {SIGINT, SIGTERM})
    expect(sd_event_add_signal(event_.get(), nullptr, sig, on_stop, nullptr), "cannot watch signals");
}

int Watch::run(const std::string& node_path) {
  sd_event* event = nullptr;
  expect(sd_event_new(&event), "cannot create an event loop");
  event_.reset(event);
  add_stop_signals();
  sd_bus* bus = connection_.bus();
  expect(sd_bus_attach_event(bus, event, SD_EVENT_PRIORITY_NORMAL), "cannot attach the connection");
  sd_bus_set_exit_on_disconnect(bus, 1);  // the loop ends with 1 when the daemon goes
  std::string rule = "type='signal'," + (node_path.empty() ? "path_namespace='" + std::string(kFleetPath) + "'"
                                                           : "path='" + node_path + "'");
  sd_bus_slot* slot = nullptr;
  expect(sd_bus_add_match(bus, &slot, rule.c_str(), on_message, this), "cannot add a match rule");
  std::unique_ptr<sd_bus_slot, SlotUnref> match(slot);
  connection_.call(kFleetPath, kFleetInterface, "Subscribe");
  int r = sd_event_loop(event);
  sd_bus_detach_event(bus);
  if (!error_.empty()) throw Failure(error_);
  expect(r, "event loop failed");
  if (r != 0) throw Failure("cansimd closed the connection");
  return 0;
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
  return rows;
}

bool is_socket(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_socket(path, ec);
}

}  // namespace

int run_request(Connection& connection, const Request& request, Printer& printer) {
  if (request.output == Output::kWatch) {
    std::string node_path = request.node.empty() ? "" : connection.node_path(request.node);
    return Watch(connection, printer).run(node_path);
  }
  std::string path = request.call.target == Target::kNode ? connection.node_path(request.node) : kFleetPath;
  std::vector<Arg> args = request.call.args;
  if (request.output == Output::kAdded) args = {Value(read_text_file(request.file))};
  MessagePtr reply = connection.call(path, request.call.interface, request.call.method, args);
  if (request.output == Output::kStats) {
    printer.stats(bus_statistics(connection, reply.get()));
    return 0;
  }
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
