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
#include <set>
#include <string>
#include <vector>

#include "config/fleet.hpp"
#include "config/limits.hpp"
#include "control/control_host.hpp"
#include "control/endpoints.hpp"
#include "control/service.hpp"
#include "core/application.hpp"
#include "io/can_interface.hpp"
#include "io/event_loop.hpp"
#include "io/loop_core.hpp"

namespace cansim::daemon {

// The profile search the daemon uses (installed profiles folder included).
config::ProfileSearch profile_search(const std::string& config_file);

// The node's Application: the personality's, wrapped so the configured serial
// number (0x1018:04) survives every reset. May return nullptr. Its recordings
// never go into `state_dir` (when given).
std::unique_ptr<Application> make_node_application(const config::NodeConfig& node, std::uint64_t seed,
                                                   const std::string& state_dir = {});

// Nodes of one fleet entry (same interface and name) whose own bit rate is not
// their bus's: they neither hear nor speak until it matches.
struct BitRateMismatch {
  std::string interface;
  std::string name;                // the entry's name (its nodes' keys: <interface>/<name>/<index>)
  std::size_t count = 0;           // nodes of the entry at the wrong rate
  std::uint8_t first_id = 0, last_id = 0;
  std::uint32_t node_kbit = 0;     // the nodes' rate
  std::uint32_t bus_kbit = 0;      // the interface's
};
// One entry per fleet entry with mismatching nodes, in fleet order.
// `bus_kbit(interface)` is the interface's effective rate.
std::vector<BitRateMismatch> bit_rate_mismatches(const config::FleetConfig& fleet,
                                                 const std::function<std::uint32_t(const config::InterfaceConfig&)>& bus_kbit);
// "vcan0/generic: 3 nodes (node-IDs 0x10..0x12) run at 250 kbit/s but vcan0 at
// 1000 kbit/s: they stay silent. Fix: set `bit_rate: 1000` on the node entry
// (or `bit_rate: 250` on interface vcan0)".
std::string describe(const BitRateMismatch& m);
// The interface's effective rate: configured, else the kernel's (real CAN), else 250.
std::uint32_t effective_bit_rate(const config::InterfaceConfig& ic);

// What the loaders repaired in the fleet's profiles (EDS / DCF), each once.
std::vector<std::string> load_warnings(const config::FleetConfig& fleet);

// --check: loads, prepares and builds every node without touching the bus.
// Returns a one-line summary; throws config::ConfigError. `warnings` (when
// given) receives what the loaders repaired (load_warnings()) and what is
// valid but probably not meant: nodes at another bit rate than their bus
// (describe()).
std::string check_fleet(config::FleetConfig& fleet, std::vector<std::string>* warnings = nullptr);

// How the core builds the node of a fleet entry: its profile's layout and
// options, node-ID, bit rate and `serial:`.
NodeSetup node_setup(const config::NodeConfig& node);

struct DaemonSettings {
  std::string state_dir = "state";
  std::optional<std::uint64_t> seed;             // --seed overrides the config's
  std::function<config::FleetConfig()> load;     // (re)reads the configuration
  std::string config_file;                       // the fleet file or the single profile
  control::BusChoice bus = control::BusChoice::kAuto;
  std::string control_socket;                    // empty: the default path; "none": no socket
  std::size_t max_clients = limits::kDefaultMaxClients;  // private-socket clients served at once
  bool strict = false;                           // --strict: nodes added at run time too
  bool strict_eds = false;                       // --strict-eds: nodes added at run time too
};

class Daemon : public control::ControlHost {
 public:
  explicit Daemon(DaemonSettings settings);
  ~Daemon() override;
  // Loads the configuration, runs until SIGTERM / SIGINT, returns the exit code.
  // Throws config::ConfigError when the initial configuration is invalid.
  int run();

  // control::ControlHost
  io::LoopCore& core() override { return core_; }
  TimeUs now() const override { return clock_now(); }
  std::vector<const control::NodeHandle*> nodes() const override;
  const control::NodeHandle* find(const std::string& key) const override;
  std::vector<std::string> add_nodes(const std::string& yaml) override;
  void remove_node(const std::string& key) override;
  void reload() override;
  std::vector<control::BusStatistics> bus_statistics() const override;
  std::vector<control::BusStatistics> buses() const override;
  bool interface_up(const std::string& name) const override;
  void log_action(const control::ActionRecord& r) override;
  std::string config_file() const override { return settings_.config_file; }

 private:
  struct Interface;
  TimeUs clock_now() const;
  struct NodeEntry {
    io::NodeRef ref = io::kNoNode;
    config::NodeConfig cfg;
    std::uint64_t seed = 0;
    std::uint8_t bus_rate = 0;
    control::NodeHandle handle;
  };
  struct Pending;

  // The running fleet: the file's nodes plus those added at run time, less
  // those removed at run time.
  config::FleetConfig combined() const;
  std::vector<std::string> profile_folders() const;
  void apply(config::FleetConfig cfg, TimeUs now);
  std::vector<Pending> plan(const config::FleetConfig& cfg, std::uint64_t seed, std::set<std::string>& wanted);
  std::pair<std::size_t, std::size_t> remove_stale(const std::set<std::string>& wanted,
                                                   const std::vector<Pending>& to_add);
  io::NodeRef add_node(Pending& p, std::uint64_t seed, std::vector<BitRateMismatch>& mismatched);
  void close_unconfigured_interfaces();
  void reload(TimeUs now);
  void start_control();
  Interface& ensure_interface(const config::InterfaceConfig& ic);
  void apply_bus_model(Interface& iface, const io::KernelLink& link);
  void remove_node(NodeEntry& e);
  void on_can_events(Interface& iface, std::uint32_t events);
  void drain(Interface& iface, TimeUs now);
  void take_controller_reports(Interface& iface, TimeUs now);
  void flush(TimeUs now);
  void sweep_interfaces(TimeUs now);
  void try_open(Interface& iface, TimeUs now);
  void housekeeping(TimeUs now);
  TimeUs housekeeping_deadline() const;
  void report_status(TimeUs now);
  void check_bus_load();
  void notify(const std::string& state);
  // READY=1 once the frames the nodes sent so far are on the wire (the
  // boot-ups: a timed bus takes its time); checked after every loop pass.
  void ready_when_sent();
  void check_ready();

  DaemonSettings settings_;
  io::EventLoop loop_;
  io::LoopCore core_;
  std::vector<std::unique_ptr<Interface>> interfaces_;
  std::map<std::string, NodeEntry> nodes_;
  config::FleetConfig file_config_;                // as last loaded from the file
  std::vector<config::FleetConfig> added_;         // AddNodes fragments, in order
  std::set<std::string> removed_;                  // RemoveNode keys (file ones until the next reload)
  std::unique_ptr<control::ControlService> control_;
  std::unique_ptr<control::ControlEndpoints> endpoints_;
  std::uint64_t fragments_ = 0;
  std::uint64_t watchdog_us_ = 0;
  TimeUs next_watchdog_ = kNever;
  TimeUs next_status_ = kNever;
  TimeUs last_status_ = 0;
  TimeUs epoch_ = 0;  // CLOCK_MONOTONIC at start: simulated time 0
  std::uint64_t last_frames_out_ = 0;
  std::uint64_t last_frames_in_ = 0;
  double frames_per_s_ = 0;
  double status_period_s_ = 0;
  std::vector<std::pair<io::BusId, std::uint64_t>> ready_marks_;
  bool ready_pending_ = false;
};

}  // namespace cansim::daemon
