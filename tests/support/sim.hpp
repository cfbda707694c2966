// Test support: nodes on an in-memory bus with a fake clock. Frames a node
// sends are recorded with the time they were sent and delivered to the other
// nodes on the bus, as on a real CAN bus (the sender does not hear itself).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "config/profile.hpp"
#include "core/node.hpp"
#include "support/memory_storage.hpp"

namespace cansim::test {

struct Sent {
  TimeUs time;
  CanFrame frame;
};

class SimBus;

// One node with its sink, storage and (optional) application.
class SimNode : public FrameSink {
 public:
  SimNode(SimBus& bus, const config::Profile& profile, std::uint8_t node_id, Application* app = nullptr,
          std::optional<std::uint32_t> serial_number = std::nullopt, std::uint64_t seed = 1);
  void send(const CanFrame& frame) override;
  Node& node() { return *node_; }
  Node* operator->() { return node_.get(); }
  MemoryStorage storage;
  // Rebuilds the Node object (simulated power loss), keeping storage.
  void replace(std::uint8_t node_id);

 private:
  SimBus& bus_;
  const config::Profile& profile_;
  Application* app_;
  std::optional<std::uint32_t> serial_number_;
  std::uint64_t seed_;
  std::unique_ptr<Node> node_;
};

class SimBus {
 public:
  SimBus() = default;
  // Adds a node built from a profile; the bus keeps the profile alive.
  // serial_number: NodeSetup::serial_number (a fleet entry's `serial:`);
  // seed: NodeSetup::seed (the node's response-time jitter).
  SimNode& add(const config::Profile& profile, std::uint8_t node_id, Application* app = nullptr,
               std::optional<std::uint32_t> serial_number = std::nullopt, std::uint64_t seed = 1);

  TimeUs now() const { return now_; }
  // Frames a test tool (the "master") puts on the bus: delivered to every node.
  void inject(const CanFrame& frame);
  // Advances simulated time to t, running every deadline on the way in order.
  void run_until(TimeUs t);
  void run_for(TimeUs dt) { run_until(now_ + dt); }
  void power_on_all();

  // Everything sent by nodes since the last take().
  std::vector<Sent> take();
  std::vector<Sent>& log() { return log_; }

  void deliver(SimNode* from, const CanFrame& frame);

 private:
  void flush();
  std::vector<std::unique_ptr<SimNode>> nodes_;
  std::deque<std::pair<SimNode*, CanFrame>> pending_;
  std::vector<Sent> log_;
  TimeUs now_ = 0;
  bool flushing_ = false;
};

// Loads a profile from profiles/<name>.yaml in the source tree.
config::Profile load_repo_profile(const std::string& name);

// Shorthand for frames in expectations: F(0x60A, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}).
inline CanFrame F(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) { return CanFrame::make(id, bytes); }
std::string to_string(const CanFrame& f);
std::string to_string(const std::vector<Sent>& frames);

}  // namespace cansim::test

namespace cansim {
// gtest printing
inline void PrintTo(const CanFrame& f, std::ostream* os) { *os << test::to_string(f); }
}  // namespace cansim
