// The cansimd daemon: builds the fleet from a FleetConfig (personalities,
// stored parameters, serial numbers), runs it in one epoll loop on SocketCAN
// interfaces, reloads on SIGHUP (only added / removed / changed nodes are
// touched), stops on SIGTERM / SIGINT, and talks to systemd (READY, STATUS,
// WATCHDOG, RELOADING, STOPPING).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "config/fleet.hpp"
#include "core/application.hpp"
#include "io/can_interface.hpp"
#include "io/event_loop.hpp"
#include "io/loop_core.hpp"

namespace cansim::daemon {

// The profile search the daemon uses (installed profiles folder included).
config::ProfileSearch profile_search(const std::string& config_file);

// Runs personalities::prepare_profile on every profile of the fleet.
void prepare_fleet(config::FleetConfig& fleet);

// The node's Application: the personality's, wrapped so the configured serial
// number (0x1018:04) survives every reset. May return nullptr.
std::unique_ptr<Application> make_node_application(const config::NodeConfig& node, std::uint64_t seed);

// --check: loads, prepares and builds every node without touching the bus.
// Returns a one-line summary; throws config::ConfigError.
std::string check_fleet(config::FleetConfig& fleet);

// Sets 0x1018:04 after every reset, then lets the personality run.
class SerialOverlay : public Application {
 public:
  SerialOverlay(std::unique_ptr<Application> inner, std::uint32_t serial) : inner_(std::move(inner)), serial_(serial) {}
  void apply(Node& node);
  void on_reset(Node& n, ResetKind k, TimeUs t) override;
  void on_nmt_state(Node& n, NmtState s, TimeUs t) override;
  void refresh(Node& n, const OdEntry& e, TimeUs t) override;
  SdoAbort check_write(Node& n, const OdEntry& e, std::span<const std::uint8_t> d, TimeUs t) override;
  void after_write(Node& n, const OdEntry& e, TimeUs t) override;
  void on_sync(Node& n, std::uint8_t c, TimeUs t) override;
  TimeUs process(Node& n, TimeUs t) override;
  TimeUs environment(Node& n, TimeUs t) override;

 private:
  std::unique_ptr<Application> inner_;
  std::uint32_t serial_;
};

struct DaemonSettings {
  std::string state_dir = "state";
  std::optional<std::uint64_t> seed;             // --seed overrides the config's
  std::function<config::FleetConfig()> load;     // (re)reads the configuration
};

class Daemon {
 public:
  explicit Daemon(DaemonSettings settings);
  ~Daemon();
  // Loads the configuration, runs until SIGTERM / SIGINT, returns the exit code.
  // Throws config::ConfigError when the initial configuration is invalid.
  int run();

 private:
  struct Interface;
  TimeUs clock_now() const;
  struct NodeEntry {
    io::NodeRef ref = io::kNoNode;
    config::NodeConfig cfg;
    std::uint64_t seed = 0;
    std::uint8_t bus_rate = 0;
  };
  struct Pending;

  void apply(config::FleetConfig cfg, TimeUs now);
  void reload(TimeUs now);
  Interface& ensure_interface(const config::InterfaceConfig& ic);
  void remove_node(NodeEntry& e);
  void on_can_events(Interface& iface, std::uint32_t events);
  void drain(Interface& iface, TimeUs now);
  void flush(TimeUs now);
  void sweep_interfaces(TimeUs now);
  void try_open(Interface& iface, TimeUs now);
  void housekeeping(TimeUs now);
  TimeUs housekeeping_deadline() const;
  void report_status(TimeUs now);
  void check_bus_load();
  void notify(const std::string& state);

  DaemonSettings settings_;
  io::EventLoop loop_;
  io::LoopCore core_;
  std::vector<std::unique_ptr<Interface>> interfaces_;
  std::map<std::string, NodeEntry> nodes_;
  std::uint64_t watchdog_us_ = 0;
  TimeUs next_watchdog_ = kNever;
  TimeUs next_status_ = kNever;
  TimeUs last_status_ = 0;
  TimeUs epoch_ = 0;  // CLOCK_MONOTONIC at start: simulated time 0
  std::uint64_t last_frames_out_ = 0;
  std::uint64_t last_frames_in_ = 0;
  double frames_per_s_ = 0;
};

}  // namespace cansim::daemon
