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
#include "daemon/free_memory.hpp"
#include "core/application.hpp"
#include "daemon/plant_wiring.hpp"
#include "io/can_interface.hpp"
#include "io/event_loop.hpp"
#include "io/loop_core.hpp"
#include "io/socketcand_server.hpp"

namespace cansim::daemon {

struct Traffic;  // daemon/bus_load.hpp

// The profile search the daemon uses (installed profiles folder included).
config::ProfileSearch profile_search(const std::string& config_file);

// The node's Application: the personality's, wrapped so the configured serial
// number (0x1018:04) survives every reset. May return nullptr. Its recordings
// never go into `state_dir` (when given). `plants` resolves what its physics
// reads of the fleet's plants.
std::unique_ptr<Application> make_node_application(const config::NodeConfig& node, std::uint64_t seed,
                                                   const std::string& state_dir = {},
                                                   const physics::PlantResolver* plants = nullptr);

// Nodes of one fleet entry (same interface and name) whose own bit rate is not
// their bus's: they neither hear nor speak until it matches.
struct BitRateMismatch {
  std::string interface;
  std::string name;       // the entry's name (its nodes' keys: <interface>/<name>/<index>)
  std::size_t count = 0;  // nodes of the entry at the wrong rate
  std::uint8_t first_id = 0, last_id = 0;
  std::uint32_t node_kbit = 0;  // the nodes' rate
  std::uint32_t bus_kbit = 0;   // the interface's
};
// One entry per fleet entry with mismatching nodes, in fleet order.
// `bus_kbit(interface)` is the interface's effective rate.
std::vector<BitRateMismatch> bit_rate_mismatches(
    const config::FleetConfig& fleet, const std::function<std::uint32_t(const config::InterfaceConfig&)>& bus_kbit);
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
// options, node-ID, bit rate and `serial:`, and its own seed (its response
// times' jitter) from the fleet seed and the node's key.
NodeSetup node_setup(const config::NodeConfig& node, std::uint64_t fleet_seed);

struct DaemonSettings {
  std::string state_dir = "state";
  std::optional<std::uint64_t> seed;  // --seed overrides the config's
  // (Re)reads the configuration; a profile file whose text `store` holds
  // is not parsed again (the search's ProfileSearch::store).
  std::function<config::FleetConfig(config::ProfileStore* store)> load;
  std::string config_file;  // the fleet file or the single profile
  control::BusChoice bus = control::BusChoice::kAuto;
  std::string control_socket;                            // empty: the default path; "none": no socket
  std::size_t max_clients = limits::kDefaultMaxClients;  // private-socket clients served at once
  bool strict = false;                                   // --strict: nodes added at run time too
  bool strict_eds = false;                               // --strict-eds: nodes added at run time too
  // --address-file: written (atomically) before every READY=1, one line per
  // socketcand bus "NAME HOST PORT"; removed at exit. Empty: none.
  std::string address_file;
  // --socketcand: every interface of the fleet (and of AddNodes) is served as
  // a socketcand bus of the same name on 127.0.0.1, a free port each.
  bool socketcand = false;
};

class Daemon : public control::ControlHost {
 public:
  // Throws std::runtime_error when its event loop cannot be created.
  explicit Daemon(DaemonSettings settings);
  ~Daemon() override;
  // Loads the configuration, runs until SIGTERM / SIGINT, returns the exit code.
  // Throws config::ConfigError when the initial configuration is invalid.
  int run();
  // What run() does before its loop: loads the configuration, builds the
  // fleet and the control API (bench/limits_bench calls the fleet methods
  // of a Daemon started so, without its loop).
  void start();
  // The control API's service (null before start()).
  control::ControlService* control() { return control_.get(); }

  // control::ControlHost
  io::LoopCore& core() override { return core_; }
  TimeUs now() const override { return clock_now(); }
  std::vector<const control::NodeHandle*> nodes() const override;
  std::vector<const control::NodeHandle*> nodes_on(const std::string& interface) const override;
  const control::NodeHandle* find(const std::string& key) const override;
  std::vector<std::string> add_nodes(const std::string& yaml) override;
  void remove_node(const std::string& key) override;
  void reload() override;
  void reset() override;
  std::vector<control::BusStatistics> bus_statistics() const override;
  std::vector<control::BusStatistics> buses() const override;
  bool interface_up(const std::string& name) const override;
  void log_action(const control::ActionRecord& r) override;
  physics::PlantSet* plants() override { return plants_.plants(); }
  const config::PlantsConfig* plant_config() const override { return &plants_.config(); }
  std::string config_file() const override { return settings_.config_file; }
  std::vector<std::string> profile_folders() const override;
  TimeUs longest_loop_pass() const override { return passes_.longest(io::monotonic_now()); }
  TimeUs longest_loop_pass_cpu() const override { return pass_cpu_.longest(io::monotonic_now()); }
  std::size_t queue_frames(const std::string& interface, const std::vector<control::ScheduledFrame>& frames) override;

 private:
  struct Interface;
  TimeUs clock_now() const;
  static constexpr std::uint64_t kFileSource = 0;  // a node of the fleet file (else: its AddNodes call's number)
  struct NodeEntry {
    io::NodeRef ref = io::kNoNode;
    config::NodeConfig cfg;
    std::uint64_t seed = 0;
    std::uint8_t bus_rate = 0;
    std::uint64_t source = kFileSource;
    std::uint64_t seen = 0;  // the last apply() that kept it
    bool restart = false;    // apply() replaces it
    control::NodeHandle handle;
  };
  struct Pending;
  // The running fleet as one configuration, without copies: the file's
  // nodes less those removed at run time, then each AddNodes fragment's,
  // each with its source; the interfaces as first declared; their index.
  struct Combined {
    std::vector<std::pair<const config::NodeConfig*, std::uint64_t>> nodes;
    std::vector<config::InterfaceConfig> interfaces;
    config::NodeIndex index;
  };

  Combined combined() const;
  std::uint64_t fleet_seed() const;
  // The whole fleet (start, reload, reset); control calls change only their
  // nodes. `erase` (Reset): every node is rebuilt, and the stored parameters
  // of these keys are erased before the new nodes load theirs.
  void apply(Combined cfg, TimeUs now, const std::set<std::string>* erase = nullptr);
  // A running bus keeps its transport and listen address (`file` names the
  // error's place).
  void check_transports(const std::vector<config::InterfaceConfig>& interfaces, const std::string& file) const;
  // `plants` resolves what the nodes read of the plants; `plants_replaced`:
  // every node that reads them is rebuilt.
  std::vector<Pending> plan(const Combined& cfg, std::uint64_t seed, std::uint64_t generation, bool rebuild,
                            const physics::PlantResolver* plants, bool plants_replaced);
  void start_nodes(std::vector<Pending>& to_add, std::uint64_t seed, std::size_t restarted, std::size_t removed,
                   std::size_t interfaces);
  void attach_plants(TimeUs now);
  std::map<std::string, NodeEntry>::iterator drop_node(std::map<std::string, NodeEntry>::iterator it, const char* why);
  io::NodeRef add_node(Pending& p, std::uint64_t seed, std::vector<BitRateMismatch>& mismatched);
  void restart(std::vector<Pending>& planned, std::size_t removed);
  void declare_all();
  void declare(std::uint64_t source, const std::vector<config::InterfaceConfig>& interfaces);
  std::vector<Pending> undeclare(std::uint64_t source, const std::vector<config::InterfaceConfig>& interfaces);
  std::vector<config::InterfaceConfig> running_interfaces() const;
  Interface* interface_named(const std::string& name);
  void close_unconfigured_interfaces();
  void reload(TimeUs now);
  void start_control();
  Interface& ensure_interface(const config::InterfaceConfig& ic);
  void apply_bus_model(Interface& iface, const io::KernelLink& link);
  void update_pacer(Interface& iface);
  void remove_node(NodeEntry& e);
  void erase_stored(const std::string& key);
  void on_can_events(Interface& iface, std::uint32_t events);
  void drain(Interface& iface, TimeUs now);
  void take_controller_reports(Interface& iface, TimeUs now);
  void log_controller_report(Interface& iface, const io::ControllerReport& r, TimeUs now);
  void report_ignored_error_frames(Interface& iface, TimeUs now);
  void flush(TimeUs now);
  void release_scheduled(TimeUs now);
  void sweep_interfaces(TimeUs now);
  void try_open(Interface& iface, TimeUs now);
  void try_listen(Interface& iface, TimeUs now);
  void write_address_file() const;
  void housekeeping(TimeUs now);
  TimeUs housekeeping_deadline() const;
  void report_status(TimeUs now);
  // The offered load of the given interfaces (none: all), one journal line each.
  void check_bus_load(const std::set<Interface*>& only);
  Traffic offered(const Interface& i) const;
  // Removed nodes' memory goes back to the kernel (malloc_trim) a little
  // after the last removal, not at each.
  void trim_later();
  void notify(const std::string& state);
  // READY=1 once the frames the nodes sent so far are on the wire (the
  // boot-ups: a timed bus takes its time); checked after every loop pass.
  void ready_when_sent();
  void check_ready();

  DaemonSettings settings_;
  io::EventLoop loop_;
  io::LoopCore core_;
  PlantWiring plants_{core_};  // before the nodes it feeds are removed, after core_
  std::uint64_t plants_seed_ = 0;
  bool plants_built_ = false;
  std::vector<std::unique_ptr<Interface>> interfaces_;
  std::map<std::string, NodeEntry> nodes_;
  config::NodeIndex index_;                             // their keys and node-IDs
  config::ProfileStore profile_store_;                  // the profiles AddNodes loaded
  config::FleetConfig file_config_;                     // as last loaded from the file
  std::map<std::uint64_t, config::FleetConfig> added_;  // AddNodes fragments with nodes left, by number
  std::set<std::string> removed_;                       // RemoveNode keys of file nodes (until the next reload)
  // Who declares each interface: the file and the fragments, by source; the
  // first one's settings hold (as in combined()).
  std::map<std::string, std::map<std::uint64_t, config::InterfaceConfig>> declared_;
  std::uint64_t generation_ = 0;  // apply() calls
  TimeUs trim_at_ = kNever;
  FreeMemory free_memory_;
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
  io::PassMeter passes_;    // wall-clock time of each loop pass
  io::PassMeter pass_cpu_;  // the CPU time each used
  bool starting_ = true;    // a socketcand bus that cannot listen at start is fatal
};

}  // namespace cansim::daemon
