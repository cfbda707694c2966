// The control API's object model on sd-bus (docs/control-api.md): the fleet
// object (io.cansim.Fleet1) and one object per node (io.cansim.Node1) served
// by a fallback vtable and a node enumerator, so thousands of nodes cost no
// per-node registration on any connection. Signals go only to connections
// that called Subscribe().
//
// The service runs on the loop thread: method handlers run from
// sd_bus_process() between loop passes and act on the nodes at once.
#pragma once

#include <systemd/sd-bus.h>

#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "control/audit.hpp"
#include "control/control_host.hpp"
#include "control/names.hpp"
#include "core/observer.hpp"
#include "io/loop_core.hpp"

namespace cansim::control {

// The object path of a node: /io/cansim/Cansimd1/node/<interface>/<name>/<index>.
std::string node_path(const NodeHandle& h);
// The object path of a plant: /io/cansim/Cansimd1/plant/<name>.
std::string plant_path(const std::string& name);

class ControlService : public io::LoopObserver {
 public:
  explicit ControlService(ControlHost& host);
  ~ControlService() override;
  ControlService(const ControlService&) = delete;
  ControlService& operator=(const ControlService&) = delete;

  // Serves the object model on a connection. `peer`: a peer-to-peer
  // connection without a bus daemon (answers Hello / AddMatch itself).
  // `peer_uid`: the peer's uid, when its connection cannot tell sd-bus
  // (ControlEndpoints reads the socket for it). Returns a negative errno on failure.
  int attach(sd_bus* bus, bool peer, std::optional<uid_t> peer_uid = std::nullopt);
  void detach(sd_bus* bus);

  // The host tells the service about fleet changes (initial nodes included).
  void node_added(const NodeHandle& h);
  void node_removed(const std::string& key);
  // A real interface's CAN controller changed state: signal BusStateChanged
  // and BusStates' PropertiesChanged to subscribers.
  void bus_state_changed(const std::string& interface, CanState old, CanState now, TimeUs t);

  // A plant's fault began or ended (the daemon's plant wiring tells it):
  // FaultStarted / FaultEnded and the Faults property to subscribers.
  void plant_fault_edge(const std::string& plant, std::uint32_t id, std::uint8_t kind, const std::string& target,
                        bool started, TimeUs t);

  // io::LoopObserver: core events become signals.
  void on_nmt_state(io::NodeRef ref, NmtState old, NmtState now, TimeUs t) override;
  void on_boot_up(io::NodeRef ref, TimeUs t) override;
  void on_emcy(io::NodeRef ref, std::uint16_t code, std::uint8_t reg, const std::uint8_t vendor[5], TimeUs t) override;
  void on_remote_write(io::NodeRef ref, const OdEntry& e, WriteVia via, TimeUs t) override;
  void on_power(io::NodeRef ref, bool powered, TimeUs t) override;
  void on_pdo_config(io::NodeRef ref, TimeUs t) override;

  // Implementation detail shared by the handler files.
  struct NodeContext;
  struct PlantContext;
  struct Connection;
  ControlHost& host() { return host_; }
  NodeContext* context(const std::string& key);
  NodeContext* context(io::NodeRef ref);
  // A plant's context (made on first use; null when the fleet has no such plant).
  PlantContext* plant_context(const std::string& name);
  bool has_subscribers() const;
  // Emits a signal on every connection with a subscriber; `build` appends the arguments.
  template <typename Build>
  void emit(const std::string& path, const char* interface, const char* member, Build&& build);
  void emit_properties_changed(const std::string& path, const char* interface,
                               std::initializer_list<const char*> names);
  void subscribe(sd_bus_message* m, bool on);
  // A method changed a node: its deadlines are re-read, its frames flushed.
  void touched(const NodeContext& n);
  void fault_edge(NodeContext& n, std::uint32_t id, std::uint8_t kind, bool started, TimeUs t);
  // Logs the control action `m` on node `key` (fleet: "") and its outcome (audit.hpp).
  void audit(sd_bus_message* m, const std::string& key, const std::string& interface, int r, const sd_bus_error* e);

 private:
  ControlHost& host_;
  ActionLimiter action_limiter_;
  CallerIds callers_;
  std::vector<std::unique_ptr<Connection>> connections_;
  std::unordered_map<std::string, std::unique_ptr<NodeContext>> by_key_;
  std::vector<NodeContext*> by_ref_;
  std::unordered_map<std::string, std::unique_ptr<PlantContext>> plants_;
};

}  // namespace cansim::control
