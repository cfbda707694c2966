// A fleet for control API tests on the fake clock: the daemon's node
// building (profiles, personalities, serial numbers) on a LoopCore with a
// MemoryTransport per bus, behind the same ControlHost interface the daemon
// implements; plus a server / client sd-bus pair over a socketpair, stepped
// by hand (no bus daemon, no thread).
#pragma once

#include <systemd/sd-bus.h>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "config/fleet.hpp"
#include "control/control_host.hpp"
#include "control/service.hpp"
#include "io/loop_core.hpp"
#include "io/transport.hpp"
#include "support/sim.hpp"

namespace cansim::test {

class ControlFleet : public control::ControlHost {
 public:
  // The transport of a bus, by name (the benchmark counts frames instead of
  // recording them). Default: a MemoryTransport on the fleet's clock.
  using TransportFactory = std::function<std::unique_ptr<io::Transport>(const std::string& bus)>;

  // `fleet_yaml`: a fleet document; profiles by name from the source tree.
  explicit ControlFleet(const std::string& fleet_yaml, TransportFactory transports = {});
  ~ControlFleet() override;

  // ControlHost
  io::LoopCore& core() override { return core_; }
  TimeUs now() const override { return now_; }
  std::vector<const control::NodeHandle*> nodes() const override;
  const control::NodeHandle* find(const std::string& key) const override;
  std::vector<std::string> add_nodes(const std::string& yaml) override;
  void remove_node(const std::string& key) override;
  void reload() override;
  std::vector<control::BusStatistics> bus_statistics() const override;
  std::string config_file() const override { return "<test>"; }

  control::ControlService& service() { return service_; }
  // Runs the fleet up to t (the fake clock).
  void run_until(TimeUs t);
  // As the daemon's loop: every due node at `now` (the benchmark's real clock).
  void run_due(TimeUs now);
  // Frames sent on a bus since the last take (with the time the core said);
  // only with the default transports.
  std::vector<io::MemoryTransport::Sent> take(const std::string& bus);
  // A frame from "the master" on a bus, at the current time.
  void receive(const std::string& bus, const CanFrame& f);
  io::BusId bus_id(const std::string& name) { return bus(name).id; }
  const control::NodeHandle& node(const std::string& key) const { return *find(key); }

 private:
  struct Bus {
    io::BusId id = 0;
    std::unique_ptr<io::Transport> wire;
    io::MemoryTransport* memory = nullptr;  // wire, when it is the default
  };
  struct Entry {
    control::NodeHandle handle;
    config::NodeConfig cfg;
  };
  Bus& bus(const std::string& name);
  void add(const config::FleetConfig& cfg);

  TransportFactory transports_;
  TimeUs now_ = 0;
  io::LoopCore core_;
  control::ControlService service_{*this};
  std::map<std::string, Bus> buses_;
  std::map<std::string, std::unique_ptr<Entry>> entries_;
  config::FleetConfig running_;
};

// A peer-to-peer sd-bus pair: `server` carries the service, `client` calls it.
class BusPair {
 public:
  explicit BusPair(control::ControlService& service);
  ~BusPair();
  // Calls a method and steps both ends until the answer; returns the reply
  // (caller unrefs) or nullptr with *error_name / *error_message set.
  sd_bus_message* call(sd_bus_message* m, std::string* error_name = nullptr, std::string* error_message = nullptr);
  // A new method call to the fleet object / a node object.
  sd_bus_message* fleet_call(const char* member);
  sd_bus_message* node_call(const std::string& path, const char* member);
  // The object path of a node (Fleet1.GetNode), "" when there is none.
  std::string node_path(const std::string& node);
  // Steps both ends until nothing is left to do.
  void pump();
  // Signals received since the last take: (member, message) — caller unrefs messages.
  std::vector<std::pair<std::string, sd_bus_message*>> take_signals();
  sd_bus* client() { return client_; }
  // Thread CPU time spent in the server's sd_bus_process() so far: what a
  // daemon's loop would have spent on these calls (ms).
  double server_cpu_ms() const { return server_cpu_ms_; }

 private:
  control::ControlService& service_;
  sd_bus* server_ = nullptr;
  sd_bus* client_ = nullptr;
  sd_bus_slot* filter_ = nullptr;
  double server_cpu_ms_ = 0;
  int serve();  // one sd_bus_process() of the server, timed
  std::vector<std::pair<std::string, sd_bus_message*>> signals_;
};

}  // namespace cansim::test
