#include "ctl/monitor.hpp"

#include <cstdio>
#include <map>
#include <set>

#include "ctl/client_loop.hpp"
#include "ctl/decode.hpp"
#include "ctl/frame_decoder.hpp"
#include "ctl/frame_source.hpp"
#include "ctl/json.hpp"
#include "ctl/time_base.hpp"

namespace cansim::ctl {

std::string node_label(const std::string& name, std::uint32_t index, bool name_shared) {
  return name_shared ? name + "/" + std::to_string(index) : name;
}

namespace {

std::string last_segment(const std::string& key) { return key.substr(key.rfind('/') + 1); }

class Monitor {
 public:
  Monitor(Connection& connection, const MonitorOptions& options, std::ostream& out)
      : connection_(connection), options_(options), out_(out), decoder_([this](NodeInfo& n) { load_objects(n); }) {}

  int run();

 private:
  void load_fleet(const std::vector<std::string>& interfaces);
  NodeInfo describe(const std::string& path, const std::string& key, const std::string& label,
                    const std::string& interface, std::uint8_t node_id);
  NodeInfo node_info(const std::string& key, const std::string& label, const std::string& interface,
                     std::uint8_t node_id, std::vector<PdoInfo> pdos);
  void refresh(const std::string& path);
  void add(const std::string& path);
  void load_objects(NodeInfo& n);
  std::vector<ObjectInfo> count_scaling(const std::string& path);
  void on_signal(sd_bus_message* m);
  void on_frames(FrameSource& source);
  void print(const DecodedFrame& f);
  void print_dropped(const FrameSource& source, const RawFrame& next);
  std::vector<std::string> fleet_interfaces();

  Connection& connection_;
  const MonitorOptions& options_;
  std::ostream& out_;
  FrameDecoder decoder_;
  std::string only_key_;
  TimeBase clock_;  // a frame's wall time -> the daemon's simulated time
  std::map<std::string, std::string> path_by_key_;
  std::map<std::string, int> name_count_;
  std::map<const FrameSource*, std::uint64_t> dropped_shown_;
};

std::string path_of(sd_bus_message* m) {
  const char* p = sd_bus_message_get_path(m);
  return p ? p : "";
}

NodeInfo Monitor::node_info(const std::string& key, const std::string& label, const std::string& interface,
                            std::uint8_t node_id, std::vector<PdoInfo> pdos) {
  NodeInfo n;
  n.key = key;
  n.label = label;
  n.interface = interface;
  n.node_id = node_id;
  n.pdos = std::move(pdos);
  return n;
}

// One node's PDOs asked of it (a node added or changed while monitoring).
NodeInfo Monitor::describe(const std::string& path, const std::string& key, const std::string& label,
                           const std::string& interface, std::uint8_t node_id) {
  NodeInfo n = node_info(key, label, interface, node_id,
                         read_pdo_infos(connection_.call(path, kNodeInterface, "GetPdoMapping").get()));
  std::vector<ObjectInfo*> counts = counts_of(n.pdos);
  if (!counts.empty()) attach_count_scaling(counts, count_scaling(path));
  return n;
}

std::vector<ObjectInfo> Monitor::count_scaling(const std::string& path) {
  return read_count_scaling(connection_.call(path, kNodeInterface, "ListCountScaling").get());
}

// The plant inputs carried by frames (Fleet1.ListPlantSignals).
std::vector<PlantSignalInfo> plant_signals(Connection& c) {
  MessagePtr reply = c.call(kFleetPath, kFleetInterface, "ListPlantSignals");
  sd_bus_message* m = reply.get();
  std::vector<PlantSignalInfo> out;
  expect(sd_bus_message_enter_container(m, 'a', "(sssubqyybdds)"), "unexpected reply from cansimd");
  const char *plant = nullptr, *input = nullptr, *iface = nullptr, *unit = nullptr;
  PlantSignalInfo p;
  int extended = 0, little = 0;
  std::uint8_t type = 0;
  int r;
  while ((r = sd_bus_message_read(m, "(sssubqyybdds)", &plant, &input, &iface, &p.signal.can_id, &extended,
                                  &p.signal.start, &p.signal.length, &type, &little, &p.signal.scale, &p.signal.offset,
                                  &unit)) > 0) {
    p.plant = plant, p.input = input, p.interface = iface, p.unit = unit;
    p.signal.extended = extended, p.signal.little_endian = little;
    p.signal.type = CanSignal::Type(std::min<std::uint8_t>(type, 2));
    out.push_back(p);
  }
  expect(r, "unexpected reply from cansimd");
  return out;
}

// The PDOs of every node of each bus monitored in one call a bus
// (GetPdoMappings): 1,000 nodes on 8 buses in 9 round trips. A node that came
// between the calls is asked alone.
void Monitor::load_fleet(const std::vector<std::string>& interfaces) {
  decoder_.set_plant_signals(plant_signals(connection_));
  std::vector<NodeRow> rows = read_node_rows(connection_.call(kFleetPath, kFleetInterface, "ListNodes").get());
  const std::set<std::string> monitored(interfaces.begin(), interfaces.end());
  std::map<std::string, std::vector<PdoInfo>> pdos;
  for (const std::string& name : monitored)
    pdos.merge(
        read_fleet_pdo_mappings(connection_.call(kFleetPath, kFleetInterface, "GetPdoMappings", {Value(name)}).get()));
  for (const NodeRow& r : rows) ++name_count_[r.name];
  for (const NodeRow& r : rows) {
    if (!monitored.count(r.interface)) continue;  // its frames are not read
    path_by_key_[r.key] = r.path;
    const auto index = std::uint32_t(std::stoul(last_segment(r.key)));
    const std::string label = node_label(r.name, index, name_count_[r.name] > 1);
    auto it = pdos.find(r.key);
    decoder_.set_node(it == pdos.end() ? describe(r.path, r.key, label, r.interface, r.node_id)
                                       : node_info(r.key, label, r.interface, r.node_id, std::move(it->second)));
  }
}

// After PdoMappingChanged or a NodeId change: the node's PDOs and node-ID now.
void Monitor::refresh(const std::string& path) {
  const std::string key = node_key_of_path(path);
  NodeInfo* old = decoder_.node(key);
  if (!old) return add(path);
  std::vector<Arg> property{Value(std::string(kNodeInterface)), Value(std::string("NodeId"))};
  MessagePtr reply = connection_.call(path, kPropertiesInterface, "Get", property);
  const Value id = read_value(reply.get());
  NodeInfo n = describe(path, key, old->label, old->interface, std::get<std::uint8_t>(id));
  decoder_.set_node(std::move(n));  // objects reloaded when an SDO needs them (units may have changed)
}

void Monitor::add(const std::string& path) {
  MessagePtr reply = connection_.call(path, kPropertiesInterface, "GetAll", {Value(std::string(kNodeInterface))});
  NodeStatus s = read_node_status(reply.get());
  path_by_key_[s.key] = path;
  const bool shared = ++name_count_[s.name] > 1 || s.index > 0;
  decoder_.set_node(describe(path, s.key, node_label(s.name, s.index, shared), s.interface, s.node_id));
}

// What SDO and EMCY frames need: the node's objects and its EMCY codes.
void Monitor::load_objects(NodeInfo& n) {
  auto it = path_by_key_.find(n.key);
  if (it == path_by_key_.end()) return;
  if (!n.objects) {
    n.objects = read_object_infos(connection_.call(it->second, kNodeInterface, "ListObjects").get());
    std::vector<ObjectInfo*> counts;
    for (ObjectInfo& o : *n.objects)
      if (o.unit == kCountsUnit) counts.push_back(&o);
    if (!counts.empty()) attach_count_scaling(counts, count_scaling(it->second));
  }
  if (!n.emcy_codes)
    n.emcy_codes = read_emcy_codes(connection_.call(it->second, kNodeInterface, "ListEmcyCodes").get());
}

void Monitor::on_signal(sd_bus_message* m) {
  const std::string member = sd_bus_message_get_member(m);
  if (member == "PdoMappingChanged") return refresh(path_of(m));
  if (member == "NodeAdded" || member == "NodeRemoved") {
    const char *path = nullptr, *key = nullptr;
    expect(sd_bus_message_read(m, "os", &path, &key), "unexpected signal from cansimd");
    if (member == "NodeAdded") return add(path);
    decoder_.remove_node(key);
    path_by_key_.erase(key);
    return;
  }
  if (member != "PropertiesChanged") return;
  Event e = read_event(m);
  for (const Field& f : e.fields) {
    const auto* id = std::get_if<std::uint8_t>(&f.value);
    NodeInfo* n = decoder_.node(e.source);
    if (f.name == "NodeId" && id && n && n->node_id != *id) return refresh(path_of(m));
  }
}

void Monitor::print(const DecodedFrame& f) {
  if (!only_key_.empty() && f.node != only_key_) return;
  if (options_.json) print_json(out_, decoded_json(f));
  else out_ << format_decoded(f) << '\n';
}

// Frames the kernel dropped before `next` came (its socket's queue was
// full): never silently, one record before the frame that follows them.
void Monitor::print_dropped(const FrameSource& source, const RawFrame& next) {
  std::uint64_t& shown = dropped_shown_[&source];
  if (source.dropped() == shown) return;
  const std::uint64_t lost = source.dropped() - shown;
  shown = source.dropped();
  if (options_.json) {
    print_json(out_, {{"time", next.simulated_time ? json_number(*next.simulated_time) : Json(nullptr)},
                      {"wall_time", next.time},
                      {"interface", source.interface()},
                      {"node", nullptr},
                      {"kind", "dropped"},
                      {"dropped", lost},
                      {"dropped_total", shown}});
  } else {
    out_ << source.interface() << ": " << lost
         << " frame(s) dropped before cansimctl read them (its socket's receive queue was full), " << shown
         << " since monitor started\n";
  }
}

void Monitor::on_frames(FrameSource& source) {
  RawFrame frame;
  while (source.receive(frame)) {
    frame.simulated_time = clock_.simulated(frame.time);
    print_dropped(source, frame);
    print(decoder_.decode(frame));
  }
  out_.flush();
}

std::vector<std::string> Monitor::fleet_interfaces() {
  MessagePtr reply = connection_.call(kFleetPath, kFleetInterface, "GetBusStatistics");
  std::vector<std::string> names;
  for (const BusStats& b : read_bus_stats(reply.get())) names.push_back(b.name);
  return names;
}

int Monitor::run() {
  ClientLoop loop(connection_);
  loop.on_signals("type='signal',path_namespace='" + std::string(kFleetPath) + "'",
                  [this](sd_bus_message* m) { on_signal(m); });
  connection_.call(kFleetPath, kFleetInterface, "Subscribe");
  if (!options_.node.empty()) only_key_ = node_key_of_path(connection_.node_path(options_.node));
  clock_ = TimeBase::of(connection_);
  std::vector<std::string> names = options_.interfaces.empty() ? fleet_interfaces() : options_.interfaces;
  load_fleet(names);
  const SocketcandAddresses served = socketcand_addresses(connection_);
  std::vector<std::unique_ptr<FrameSource>> sockets;
  std::string errors;
  for (const std::string& name : names) {
    try {
      sockets.push_back(open_frame_source(name, served, options_.timeout_s));
    } catch (const Failure& e) {
      if (!options_.interfaces.empty()) throw;
      errors += std::string(errors.empty() ? "" : "; ") + e.what();
    }
  }
  if (sockets.empty()) throw Failure(errors.empty() ? "the fleet has no interface" : errors);
  if (!errors.empty()) std::fprintf(stderr, "cansimctl: %s\n", errors.c_str());
  for (auto& s : sockets) loop.on_readable(s->fd(), [this, socket = s.get()] { on_frames(*socket); });
  return loop.run("monitor", options_.json);
}

}  // namespace

int run_monitor(Connection& connection, const MonitorOptions& options, std::ostream& out) {
  return Monitor(connection, options, out).run();
}

}  // namespace cansim::ctl
