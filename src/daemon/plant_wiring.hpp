// The running fleet's plants (docs/plants.md) and what feeds them from the
// loop: the engine (physics::PlantSet), the controller's commands decoded as
// their frames enter the loop core (io::FrameTap: every transport), the
// objects a master writes into simulated nodes (a LoopObserver in front of
// the control service's: no polling) and the outputs of actuator nodes
// (pulled at every plant step, with a listener that advances the plant
// before an output's command changes).
//
// Decisions:
//  * A binding holds NodeRefs and application pointers: detach() before any
//    node is removed or the plants are replaced, attach() once the fleet is
//    built again (Daemon::apply does both around its changes).
//  * Lookups on the frame and write paths are hash maps built by attach():
//    nothing allocates there.
//  * A NaN or an infinity from a block is logged with the plant and the
//    block: the first one at once, then at most every 10 s with the count.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "config/plant_config.hpp"
#include "io/loop_core.hpp"
#include "physics/plant.hpp"

namespace cansim::daemon {

class PlantWiring : public io::FrameTap, public io::LoopObserver {
 public:
  explicit PlantWiring(io::LoopCore& core);
  ~PlantWiring() override;
  PlantWiring(const PlantWiring&) = delete;
  PlantWiring& operator=(const PlantWiring&) = delete;

  // Builds the plants of `cfg` (throws config::ConfigError naming the place);
  // what replace() installs.
  static std::unique_ptr<physics::PlantSet> build(const config::PlantsConfig& cfg, std::uint64_t seed);
  // Installs a new set of plants with their bindings (detached): call
  // between detach() and attach().
  void replace(std::unique_ptr<physics::PlantSet> plants, const config::PlantsConfig& cfg);
  physics::PlantSet* plants() const { return plants_.get(); }
  const config::PlantsConfig& config() const { return config_; }
  // The resolver node applications read plants through (null: no plants).
  const physics::PlantResolver* resolver() const { return resolver_.get(); }

  // Binds the inputs to the running nodes and interfaces: `node` gives a
  // node's NodeRef by key (io::kNoNode: not running), `bus` an interface's
  // BusId (false: none). Inputs whose node or interface is missing stay
  // unbound (they hold, or time out).
  void attach(const std::function<io::NodeRef(const std::string&)>& node,
              const std::function<bool(const std::string&, io::BusId&)>& bus, TimeUs now);
  void detach(TimeUs now);

  // The events of the nodes go on to `next` (the control service).
  void set_next(io::LoopObserver* next) { next_ = next; }
  // Told of every plant fault edge (after the journal line).
  using FaultListener = std::function<void(const std::string& plant, physics::FaultHandle id, physics::FaultKind kind,
                                           const std::string& target, bool started, TimeUs t)>;
  void set_fault_listener(FaultListener listener) { fault_listener_ = std::move(listener); }
  // Plant fault edges: when the next is due (kNever: none), and the plants
  // with an edge due brought to now (their faults begin and end on time).
  TimeUs next_deadline() const;
  void run_due(TimeUs now);

  // io::FrameTap
  void on_frame(io::BusId bus, const CanFrame& frame, TimeUs now) override;
  // io::LoopObserver
  void on_nmt_state(io::NodeRef ref, NmtState old, NmtState now, TimeUs t) override;
  void on_boot_up(io::NodeRef ref, TimeUs t) override;
  void on_emcy(io::NodeRef ref, std::uint16_t code, std::uint8_t reg, const std::uint8_t vendor[5], TimeUs t) override;
  void on_remote_write(io::NodeRef ref, const OdEntry& e, WriteVia via, TimeUs t) override;
  void on_power(io::NodeRef ref, bool powered, TimeUs t) override;
  void on_pdo_config(io::NodeRef ref, TimeUs t) override;

  struct Feed;  // what one bound input reads

 private:
  static void non_finite(void* self, const std::string& plant, const std::string& block, std::uint64_t count, TimeUs t);
  static void fault_edge(void* self, const physics::Plant& plant, physics::FaultHandle id, physics::FaultKind kind,
                         bool started, TimeUs t);
  void push(const Feed& f, double raw, TimeUs now);

  io::LoopCore& core_;
  io::LoopObserver* next_ = nullptr;
  FaultListener fault_listener_;
  std::unique_ptr<physics::PlantSet> plants_;
  std::unique_ptr<physics::PlantSetResolver> resolver_;
  config::PlantsConfig config_;
  std::vector<std::unique_ptr<Feed>> feeds_;                               // stable addresses: ExternalSource contexts
  std::unordered_map<std::uint64_t, std::vector<const Feed*>> by_frame_;   // (bus, CAN-ID)
  std::unordered_map<std::uint64_t, std::vector<const Feed*>> by_object_;  // (node, index, sub)
  std::vector<io::BusId> tapped_buses_;
  struct Logged {
    TimeUs at = -1;
    std::uint64_t count = 0;
  };
  std::map<std::string, Logged> logged_;  // plant/block -> the last journal line
};

}  // namespace cansim::daemon
