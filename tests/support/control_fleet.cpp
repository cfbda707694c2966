#include "support/control_fleet.hpp"

#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <stdexcept>

#include "daemon/daemon.hpp"

namespace cansim::test {

namespace {
config::ProfileSearch source_profiles() {
  config::ProfileSearch s;
  s.dirs.push_back(std::string(CANSIM_SOURCE_DIR) + "/profiles");
  return s;
}
}  // namespace

ControlFleet::ControlFleet(const std::string& fleet_yaml, TransportFactory transports)
    : transports_(std::move(transports)) {
  configured_ = config::parse_fleet(fleet_yaml, "<test>", source_profiles());
  running_ = configured_;
  plants_.replace(daemon::PlantWiring::build(running_.plants, running_.seed), running_.plants);
  plants_.set_next(&service_);
  plants_.set_fault_listener(
      [this](const std::string& plant, physics::FaultHandle id, physics::FaultKind kind, const std::string& target,
             bool started, TimeUs t) { service_.plant_fault_edge(plant, id, std::uint8_t(kind), target, started, t); });
  core_.set_observer(&plants_);
  add(running_);
}

ControlFleet::~ControlFleet() {
  plants_.detach(now_);
  core_.set_observer(nullptr);
  for (auto& [key, e] : entries_) core_.remove_node(e->handle.ref);
}

ControlFleet::Bus& ControlFleet::bus(const std::string& name) {
  auto it = buses_.find(name);
  if (it != buses_.end()) return it->second;
  Bus& b = buses_[name];
  if (transports_) {
    b.wire = transports_(name);
  } else {
    auto memory = std::make_unique<io::MemoryTransport>(&core_.now());
    b.memory = memory.get();
    b.wire = std::move(memory);
  }
  b.id = core_.add_bus(name, *b.wire, 3);
  // Ideal unless the fleet says `bus_model: timed` (the daemon's vcan default
  // would change every frame time the control tests state).
  if (const config::InterfaceConfig* ic = running_.interface(name);
      ic && ic->bus_model == config::BusModelChoice::kTimed)
    core_.set_bus_model(b.id, io::BusModel::kTimed);
  return b;
}

void ControlFleet::add(const config::FleetConfig& cfg) {
  std::vector<io::NodeRef> fresh;
  for (const config::NodeConfig& n : cfg.nodes) {
    const NodeSetup setup = daemon::node_setup(n, cfg.seed);
    auto e = std::make_unique<Entry>();
    e->cfg = n;
    e->handle.key = n.key;
    e->handle.name = n.name;
    e->handle.index = n.index;
    e->handle.profile = n.profile->name;
    e->handle.personality = n.profile->personality;
    e->handle.interface = n.interface;
    e->handle.ref =
        core_.add_node(bus(n.interface).id, setup, daemon::make_node_application(n, cfg.seed, {}, plants_.resolver()),
                       std::make_unique<MemoryStorage>());
    e->handle.app = core_.app(e->handle.ref);
    e->handle.emcy_codes = &n.profile->emcy_codes;
    fresh.push_back(e->handle.ref);
    Entry& stored = *(entries_[n.key] = std::move(e));
    service_.node_added(stored.handle);
  }
  attach_plants();
  for (io::NodeRef ref : fresh) core_.power_on(ref, now_);
}

void ControlFleet::attach_plants() {
  plants_.attach(
      [this](const std::string& key) {
        auto it = entries_.find(key);
        return it == entries_.end() ? io::kNoNode : it->second->handle.ref;
      },
      [this](const std::string& name, io::BusId& id) {
        if (!running_.interface(name)) return false;
        id = bus(name).id;
        return true;
      },
      now_);
}

std::vector<const control::NodeHandle*> ControlFleet::nodes() const {
  std::vector<const control::NodeHandle*> out;
  for (const auto& [key, e] : entries_) out.push_back(&e->handle);
  return out;
}

const control::NodeHandle* ControlFleet::find(const std::string& key) const {
  auto it = entries_.find(key);
  return it == entries_.end() ? nullptr : &it->second->handle;
}

std::vector<std::string> ControlFleet::profile_folders() const {
  std::vector<std::string> dirs = source_profiles().dirs;
  dirs.insert(dirs.end(), folders_.begin(), folders_.end());
  return dirs;
}

std::vector<std::string> ControlFleet::add_nodes(const std::string& yaml) {
  config::ProfileSearch search = source_profiles();
  search.confined_to = profile_folders();
  config::FleetConfig extra = config::parse_fleet_fragment(yaml, "<AddNodes>", search, running_);
  config::FleetConfig merged = running_;
  config::merge_fleet(merged, extra);
  running_ = merged;
  add(extra);
  std::vector<std::string> keys;
  for (const auto& n : extra.nodes) keys.push_back(n.key);
  return keys;
}

void ControlFleet::remove_node(const std::string& key) {
  auto it = entries_.find(key);
  if (it == entries_.end()) return;
  service_.node_removed(key);
  plants_.detach(now_);
  core_.remove_node(it->second->handle.ref);
  entries_.erase(it);
  std::erase_if(running_.nodes, [&](const config::NodeConfig& n) { return n.key == key; });
  attach_plants();
}

void ControlFleet::reset() {
  for (auto& [key, e] : entries_) {
    service_.node_removed(key);
    core_.remove_node(e->handle.ref);
  }
  entries_.clear();
  running_ = configured_;
  add(running_);
}

void ControlFleet::reload() { throw config::ConfigError("<test>: no configuration file to reload"); }

std::vector<control::BusStatistics> ControlFleet::bus_statistics() const {
  std::vector<control::BusStatistics> out;
  for (const auto& [name, b] : buses_) {
    control::BusStatistics s;
    s.name = name;
    s.up = true;
    s.bit_rate_kbit = 250;
    s.frames_out = b.memory ? b.memory->log.size() : 0;
    s.model = core_.bus_model(b.id) == io::BusModel::kTimed ? "timed" : "ideal";
    s.state = core_.controller_state(b.id);
    s.load = core_.bus_load(b.id);
    out.push_back(s);
  }
  return out;
}

void ControlFleet::run_until(TimeUs t) {
  for (;;) {
    TimeUs next = kNever;
    for (auto& [name, b] : buses_) next = std::min(next, b.scheduled->next());
    if (next > t) break;
    now_ = std::max(now_, next);
    core_.run_until(now_);
    for (auto& [name, b] : buses_) {
      const io::BusId id = b.id;  // clang 14 cannot capture a structured binding
      b.scheduled->release(now_, [&](const CanFrame& f) { core_.submit(id, f, io::kReplayParticipant, now_); });
    }
  }
  now_ = t;
  core_.run_until(t);
  plants_.run_due(t);
}

std::size_t ControlFleet::queue_frames(const std::string& interface,
                                       const std::vector<control::ScheduledFrame>& frames) {
  auto it = buses_.find(interface);
  if (it == buses_.end()) throw std::out_of_range("no interface '" + interface + "' in the fleet");
  std::size_t taken = 0;
  while (taken < frames.size() && it->second.scheduled->push(frames[taken].at, frames[taken].frame)) ++taken;
  return taken;
}

void ControlFleet::run_due(TimeUs now) {
  now_ = now;
  core_.run_due(now);
}

std::vector<io::MemoryTransport::Sent> ControlFleet::take(const std::string& name) {
  Bus& b = bus(name);
  if (!b.memory) throw std::logic_error("ControlFleet::take: " + name + " has a caller's transport");
  return b.memory->take();
}

void ControlFleet::receive(const std::string& name, const CanFrame& f) { core_.receive(bus(name).id, f, now_); }

// ---------------------------------------------------------------- BusPair

BusPair::BusPair(control::ControlService& service, Mode mode) : service_(service) {
  int fds[2];
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0, fds) < 0)
    throw std::runtime_error("socketpair");
  sd_id128_t id;
  sd_id128_randomize(&id);
  sd_bus_new(&server_);
  if (mode == kGated) {  // as ControlEndpoints::serve_fd
    gate_ = std::make_unique<control::MessageGate>(fds[0], limits::kMessageBytes);
    sd_bus_set_fd(server_, gate_->input_fd(), fds[0]);
    gate_->input_taken();
    sd_bus_set_anonymous(server_, 1);
    sd_bus_negotiate_fds(server_, 0);
    control::answer_oversized(server_, *gate_);
  } else {
    sd_bus_set_fd(server_, fds[0], fds[0]);
  }
  sd_bus_set_server(server_, 1, id);
  sd_bus_new(&client_);
  sd_bus_set_fd(client_, fds[1], fds[1]);
  if (service_.attach(server_, true, mode == kGated ? std::optional<uid_t>(::geteuid()) : std::nullopt) < 0)
    throw std::runtime_error("attach");
  if (sd_bus_start(server_) < 0 || sd_bus_start(client_) < 0) throw std::runtime_error("sd_bus_start");
  sd_bus_add_filter(
      client_, &filter_,
      [](sd_bus_message* m, void* self, sd_bus_error*) -> int {
        std::uint8_t type = 0;
        if (sd_bus_message_get_type(m, &type) >= 0 && type == SD_BUS_MESSAGE_SIGNAL) {
          sd_bus_message_ref(m);
          static_cast<BusPair*>(self)->signals_.emplace_back(sd_bus_message_get_member(m), m);
        }
        return 0;
      },
      this);
  pump();
}

BusPair::~BusPair() {
  for (auto& s : signals_) sd_bus_message_unref(s.second);
  sd_bus_slot_unref(filter_);
  service_.detach(server_);
  sd_bus_close_unref(client_);
  sd_bus_close_unref(server_);
}

int BusPair::serve() {
  timespec t0, t1;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t0);
  const bool moved = gate_ && gate_->pump() != control::MessageGate::Pump::kNothing;
  int r = sd_bus_process(server_, nullptr);
  if (r == 0 && moved) r = 1;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t1);
  const double ms = double(t1.tv_sec - t0.tv_sec) * 1e3 + double(t1.tv_nsec - t0.tv_nsec) / 1e6;
  server_cpu_ms_ += ms;
  longest_serve_ms_ = std::max(longest_serve_ms_, ms);
  return r;
}

void BusPair::pump() {
  for (int idle = 0; idle < 3;) {
    int a = serve();
    int b = sd_bus_process(client_, nullptr);
    idle = (a > 0 || b > 0) ? 0 : idle + 1;
  }
}

sd_bus_message* BusPair::call(sd_bus_message* m, std::string* error_name, std::string* error_message) {
  struct Result {
    bool done = false;
    sd_bus_message* reply = nullptr;
  } result;
  sd_bus_call_async(
      client_, nullptr, m,
      [](sd_bus_message* r, void* p, sd_bus_error*) -> int {
        auto* res = static_cast<Result*>(p);
        res->done = true;
        res->reply = sd_bus_message_ref(r);
        return 1;
      },
      &result, 0);
  sd_bus_message_unref(m);
  for (int i = 0; i < 10000 && !result.done; ++i) {
    serve();
    sd_bus_process(client_, nullptr);
  }
  pump();
  if (!result.reply) throw std::runtime_error("no answer");
  if (const sd_bus_error* e = sd_bus_message_get_error(result.reply)) {
    if (error_name) *error_name = e->name ? e->name : "";
    if (error_message) *error_message = e->message ? e->message : "";
    sd_bus_message_unref(result.reply);
    return nullptr;
  }
  return result.reply;
}

sd_bus_message* BusPair::fleet_call(const char* member) {
  sd_bus_message* m = nullptr;
  sd_bus_message_new_method_call(client_, &m, nullptr, control::kRootPath, control::kFleetInterface, member);
  return m;
}

sd_bus_message* BusPair::node_call(const std::string& path, const char* member) {
  sd_bus_message* m = nullptr;
  sd_bus_message_new_method_call(client_, &m, nullptr, path.c_str(), control::kNodeInterface, member);
  return m;
}

std::string BusPair::node_path(const std::string& node) {
  sd_bus_message* m = fleet_call("GetNode");
  sd_bus_message_append(m, "s", node.c_str());
  sd_bus_message* r = call(m);
  const char* p = "";
  if (r) sd_bus_message_read(r, "o", &p);
  std::string out = p;
  if (r) sd_bus_message_unref(r);
  return out;
}

std::vector<std::pair<std::string, sd_bus_message*>> BusPair::take_signals() {
  std::vector<std::pair<std::string, sd_bus_message*>> out;
  out.swap(signals_);
  return out;
}

}  // namespace cansim::test
