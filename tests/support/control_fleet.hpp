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
#include "control/message_gate.hpp"
#include "config/limits.hpp"
#include "control/service.hpp"
#include "daemon/plant_wiring.hpp"
#include "io/frame_schedule.hpp"
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
  // Every node rebuilt from the fleet document, with empty storage.
  void reset() override;
  std::vector<control::BusStatistics> bus_statistics() const override;
  std::string config_file() const override { return "<test>"; }
  // The source tree's profiles/ and every folder allow_folder() added.
  std::vector<std::string> profile_folders() const override;
  void allow_folder(const std::string& dir) { folders_.push_back(dir); }
  // As the daemon: each bus's frames wait in a schedule until run_until reaches their time.
  std::size_t queue_frames(const std::string& interface, const std::vector<control::ScheduledFrame>& frames) override;
  physics::PlantSet* plants() override { return plants_.plants(); }
  const config::PlantsConfig* plant_config() const override { return &plants_.config(); }

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
    std::unique_ptr<io::FrameSchedule> scheduled = std::make_unique<io::FrameSchedule>(limits::kQueuedFramesPerBus);
  };
  struct Entry {
    control::NodeHandle handle;
    config::NodeConfig cfg;
  };
  Bus& bus(const std::string& name);
  void add(const config::FleetConfig& cfg);
  void attach_plants();

  TransportFactory transports_;
  TimeUs now_ = 0;
  io::LoopCore core_;
  daemon::PlantWiring plants_{core_};  // the fleet's plants, as the daemon wires them
  control::ControlService service_{*this};
  std::map<std::string, Bus> buses_;
  std::map<std::string, std::unique_ptr<Entry>> entries_;
  config::FleetConfig configured_;  // the fleet document
  config::FleetConfig running_;
  std::vector<std::string> folders_;
};

// A peer-to-peer sd-bus pair: `server` carries the service, `client` calls it.
class BusPair {
 public:
  // kGated: the server reads through a control::MessageGate, as the
  // daemon's private socket does (a message over limits::kMessageBytes is
  // answered TooLarge unread).
  enum Mode { kDirect, kGated };
  explicit BusPair(control::ControlService& service, Mode mode = kDirect);
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
  // The longest single server step (gate pump and sd_bus_process) since the
  // last take: what one loop pass would have spent at once (ms).
  double take_longest_serve_ms() {
    const double ms = longest_serve_ms_;
    longest_serve_ms_ = 0;
    return ms;
  }

 private:
  control::ControlService& service_;
  std::unique_ptr<control::MessageGate> gate_;
  sd_bus* server_ = nullptr;
  sd_bus* client_ = nullptr;
  sd_bus_slot* filter_ = nullptr;
  double server_cpu_ms_ = 0;
  double longest_serve_ms_ = 0;
  int serve();  // one sd_bus_process() of the server, timed
  std::vector<std::pair<std::string, sd_bus_message*>> signals_;
};

}  // namespace cansim::test
