// What the control API needs from whoever owns the fleet (the daemon, or a
// test's fake-clock fleet): the nodes with their names, the loop core that
// runs them, and the fleet-level operations. The control layer never builds
// or destroys nodes itself.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/application.hpp"
#include "io/loop_core.hpp"

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
  std::uint64_t offline = 0;  // frames not sent: interface down or missing
  double offered_load = 0;   // fraction of the bit rate, from the configuration
  double measured_load = 0;  // fraction of the bit rate, over the last status period
  std::string model = "ideal";  // "timed", "ideal", or "controller" (a real CAN interface)
  CanState state = CanState::kErrorActive;  // its controller's (vcan: always error-active)
  io::BusLoad load;          // what the bus carried (io::LoopCore::bus_load)
};

class ControlHost {
 public:
  virtual ~ControlHost() = default;
  virtual io::LoopCore& core() = 0;
  // Simulated time now (the caller's clock; the fake clock in tests).
  virtual TimeUs now() const = 0;
  // Every node, ordered by key.
  virtual std::vector<const NodeHandle*> nodes() const = 0;
  virtual const NodeHandle* find(const std::string& key) const = 0;
  // Adds the nodes of a YAML fragment (one entry, a list, or a fleet
  // document); returns their keys. Throws config::ConfigError, changing nothing.
  virtual std::vector<std::string> add_nodes(const std::string& yaml) = 0;
  virtual void remove_node(const std::string& key) = 0;
  // Re-reads the configuration; throws config::ConfigError, changing nothing.
  virtual void reload() = 0;
  virtual std::vector<BusStatistics> bus_statistics() const = 0;
  // The same without offered_load (the estimate from every node's OD): what
  // the bus properties need, cheap enough for any call.
  virtual std::vector<BusStatistics> buses() const { return bus_statistics(); }
  // The node's interface exists and is open (a node on a missing one is off the bus).
  virtual bool interface_up(const std::string& /*name*/) const { return true; }
  virtual std::string config_file() const = 0;
  // One control action's journal line (control/audit.hpp): the daemon logs it
  // with the node's CANSIM_NODE= / CANSIM_IFACE=; the default logs the text.
  virtual void log_action(const ActionRecord& r);
};

}  // namespace cansim::control
