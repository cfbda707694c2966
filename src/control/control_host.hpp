// What the control API needs from whoever owns the fleet (the daemon, or a
// test's fake-clock fleet): the nodes with their names, the loop core that
// runs them, and the fleet-level operations. The control layer never builds
// or destroys nodes itself.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "config/plant_config.hpp"
#include "core/application.hpp"
#include "io/loop_core.hpp"
#include "physics/plant.hpp"

namespace cansim::control {

struct ActionRecord;  // control/audit.hpp

// One node as the control API names it.
struct NodeHandle {
  std::string key;          // "vcan0/dps/0": stable, also the object path
  std::string name;         // the fleet entry's name
  std::uint32_t index = 0;  // position in a `count:` group
  std::string profile;
  std::string personality;
  std::string interface;
  io::NodeRef ref = io::kNoNode;
  Application* app = nullptr;  // the personality's application (unwrapped), may be null
  // The profile's `emcy:` meanings (model::Profile::emcy_codes); null: none.
  const std::map<std::uint16_t, std::string>* emcy_codes = nullptr;
};

struct BusStatistics {
  std::string name;
  bool up = false;
  std::uint32_t bit_rate_kbit = 0;
  std::uint64_t frames_in = 0;
  std::uint64_t frames_out = 0;
  std::uint64_t drops = 0;
  std::uint64_t offline = 0;    // frames not sent: interface down or missing
  double offered_load = 0;      // fraction of the bit rate, from the configuration
  double measured_load = 0;     // fraction of the bit rate carried over the last 10 s (= BusLoad's, at most 1)
  std::string model = "ideal";  // "timed", "ideal", or "controller" (a real CAN interface)
  CanState state = CanState::kErrorActive;  // its controller's (vcan: always error-active)
  io::BusLoad load;                         // what the bus carried (io::LoopCore::bus_load)
  // `transport: socketcand` (docs/socketcand.md): where it listens (port 0
  // while it does not) and its clients now; "socketcan" otherwise.
  std::string transport = "socketcan";
  std::string listen_host;
  std::uint16_t listen_port = 0;
  std::size_t clients = 0;
};

// A frame to put on a bus at simulated time `at` (Fleet1.QueueFrames).
struct ScheduledFrame {
  TimeUs at = 0;
  CanFrame frame;
};

class ControlHost {
 public:
  virtual ~ControlHost() = default;
  virtual io::LoopCore& core() = 0;
  // Simulated time now (the caller's clock; the fake clock in tests).
  virtual TimeUs now() const = 0;
  // Every node, ordered by key.
  virtual std::vector<const NodeHandle*> nodes() const = 0;
  // The nodes on one interface, ordered by key (a host that keeps them
  // apart answers without a look at the rest of the fleet).
  virtual std::vector<const NodeHandle*> nodes_on(const std::string& interface) const {
    std::vector<const NodeHandle*> out = nodes();
    std::erase_if(out, [&](const NodeHandle* h) { return h->interface != interface; });
    return out;
  }
  virtual const NodeHandle* find(const std::string& key) const = 0;
  // Adds the nodes of a YAML fragment (one entry, a list, or a fleet
  // document); returns their keys. Throws config::ConfigError, changing nothing.
  virtual std::vector<std::string> add_nodes(const std::string& yaml) = 0;
  virtual void remove_node(const std::string& key) = 0;
  // Re-reads the configuration; throws config::ConfigError, changing nothing.
  virtual void reload() = 0;
  // Back to power-on as configured (Fleet1.Reset): the configuration's nodes
  // (as last loaded; nodes added at run time gone, removed ones back), each
  // rebuilt and powered on with its stored parameters erased.
  virtual void reset() = 0;
  virtual std::vector<BusStatistics> bus_statistics() const = 0;
  // The same without offered_load (the estimate from every node's OD): what
  // the bus properties need, cheap enough for any call.
  virtual std::vector<BusStatistics> buses() const { return bus_statistics(); }
  // The node's interface exists and is open (a node on a missing one is off the bus).
  virtual bool interface_up(const std::string& /*name*/) const { return true; }
  virtual std::string config_file() const = 0;
  // The folders a file a client names must lie in (AddNodes' profiles, a
  // `csv:` table of SetModel or AddNodes): none by default.
  virtual std::vector<std::string> profile_folders() const { return {}; }
  // The longest pass of the loop (µs: from a wake-up to the next wait, all it
  // did in between) over the last 10 s, and the most CPU time a pass used
  // (what the loop itself spent: the other counts time other processes
  // had the CPU); 0 when not measured.
  virtual TimeUs longest_loop_pass() const { return 0; }
  virtual TimeUs longest_loop_pass_cpu() const { return 0; }
  // Frames an outside participant (a replay) puts on bus `interface`, each
  // at its time, through the bus (arbitrated with the nodes' frames on a
  // timed bus). Returns how many it took: those that fit in the bus's queue
  // (limits::kQueuedFramesPerBus), the first ones. Throws std::out_of_range
  // naming an unknown interface; the default takes none.
  virtual std::size_t queue_frames(const std::string& /*interface*/, const std::vector<ScheduledFrame>& /*frames*/) {
    return 0;
  }
  // One control action's journal line (control/audit.hpp): the daemon logs it
  // with the node's CANSIM_NODE= / CANSIM_IFACE=; the default logs the text.
  virtual void log_action(const ActionRecord& r);
  // The fleet's plants (docs/plants.md) and their configuration (the
  // bindings of their inputs); null: none.
  virtual physics::PlantSet* plants() { return nullptr; }
  virtual const config::PlantsConfig* plant_config() const { return nullptr; }
};

}  // namespace cansim::control
