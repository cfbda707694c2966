#include "support/sim.hpp"

#include <cstdio>
#include <ostream>

namespace cansim::test {

SimNode::SimNode(SimBus& bus, const config::Profile& profile, std::uint8_t node_id, Application* app,
                 std::optional<std::uint32_t> serial_number, std::uint64_t seed)
    : bus_(bus), profile_(profile), app_(app), serial_number_(serial_number), seed_(seed) {
  replace(node_id);
}

void SimNode::replace(std::uint8_t node_id) {
  NodeSetup setup = config::node_setup(profile_, node_id);
  if (serial_number_) setup.serial_number = serial_number_;
  setup.seed = seed_;
  node_ = std::make_unique<Node>(setup, *this, app_, &storage);
}

void SimNode::send(const CanFrame& frame) { bus_.deliver(this, frame); }

SimNode& SimBus::add(const config::Profile& profile, std::uint8_t node_id, Application* app,
                     std::optional<std::uint32_t> serial_number, std::uint64_t seed) {
  nodes_.push_back(std::make_unique<SimNode>(*this, profile, node_id, app, serial_number, seed));
  return *nodes_.back();
}

void SimBus::deliver(SimNode* from, const CanFrame& frame) {
  log_.push_back({now_, frame});
  pending_.emplace_back(from, frame);
  flush();
}

void SimBus::inject(const CanFrame& frame) {
  pending_.emplace_back(nullptr, frame);
  flush();
}

// Deliveries are queued so a node never re-enters itself while sending.
void SimBus::flush() {
  if (flushing_) return;
  flushing_ = true;
  while (!pending_.empty()) {
    auto [from, frame] = pending_.front();
    pending_.pop_front();
    for (auto& n : nodes_)
      if (n.get() != from) n->node().on_frame(frame, now_);
  }
  flushing_ = false;
}

void SimBus::run_until(TimeUs t) {
  for (;;) {
    TimeUs next = kNever;
    for (auto& n : nodes_) next = std::min(next, n->node().next_deadline());
    if (next > t) break;
    now_ = std::max(now_, next);
    for (auto& n : nodes_)
      if (n->node().next_deadline() <= now_) n->node().advance(now_);
    flush();
  }
  now_ = std::max(now_, t);
}

void SimBus::power_on_all() {
  for (auto& n : nodes_) n->node().power_on(now_);
  flush();
}

std::vector<Sent> SimBus::take() {
  std::vector<Sent> out;
  out.swap(log_);
  return out;
}

config::Profile load_repo_profile(const std::string& name) {
  return config::load_profile(std::string(CANSIM_SOURCE_DIR) + "/profiles/" + name + ".yaml");
}

std::string to_string(const CanFrame& f) {
  char buf[64];
  int n = std::snprintf(buf, sizeof buf, "%03X%s [%u]", f.id, f.rtr() ? " RTR" : "", f.dlc);
  std::string s(buf, n);
  if (!f.rtr())
    for (int i = 0; i < f.dlc; ++i) {
      std::snprintf(buf, sizeof buf, " %02X", f.data[i]);
      s += buf;
    }
  return s;
}

std::string to_string(const std::vector<Sent>& frames) {
  std::string s;
  for (const auto& x : frames) s += std::to_string(x.time) + "us " + to_string(x.frame) + "\n";
  return s;
}

}  // namespace cansim::test
