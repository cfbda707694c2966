// The machinery of the node fuzz target (fuzz/node_fuzz.cpp), shared with its
// unit test: one node of a profile, with its application and storage, fed an
// input of (time step, frame) records (the record layout is described in
// fuzz/node_fuzz.cpp).
//
// The node, application and storage are built and powered on once, at time 0,
// and snapshotted right after that power-on (Node::snapshot,
// Application::snapshot, the storage blob). Every input starts by restoring
// all three: the OD values, every service with its timers and transfers, the
// physics with its random state, the armed faults and what was stored are
// then exactly as after the first power-on, whatever the inputs before did.
// So no state leaks from one input into the next and a crash input
// reproduces when run alone (node_fuzz_test runs inputs A, B, A and compares
// every frame the two runs of A sent).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "config/profile.hpp"
#include "core/node.hpp"
#include "personalities/measurement_control.hpp"

namespace cansim::test {

// The profile as the fuzz target runs it: the CiA 404 event checks every
// 100 ms instead of 10 ms and the sensor sampling at 100 Hz / 10 Hz instead
// of 1 kHz / 100 Hz (same code paths, a tenth of the physics work per
// simulated second), prepared by its personality.
config::Profile node_fuzz_profile(const std::string& path);

struct SentFrame {
  TimeUs time;
  CanFrame frame;
  bool operator==(const SentFrame&) const = default;
};

class NodeFuzzHarness {
 public:
  // Aborts when the profile's application cannot take snapshots.
  explicit NodeFuzzHarness(const config::Profile& profile);
  ~NodeFuzzHarness();
  NodeFuzzHarness(const NodeFuzzHarness&) = delete;
  NodeFuzzHarness& operator=(const NodeFuzzHarness&) = delete;

  // Runs one input from the state right after the power-on. An invalid frame
  // sent or a deadline that does not move (the daemon would spin) aborts:
  // a crash for libFuzzer.
  void run(std::span<const std::uint8_t> input);

  // Tests: keep every frame the node sends, with its time (off by default:
  // the fuzz target does not allocate per frame).
  void record_frames(bool on) { recording_ = on; }
  const std::vector<SentFrame>& frames() const { return sink_.sent; }

 private:
  class CheckingSink : public FrameSink {
   public:
    void send(const CanFrame& f) override;
    const TimeUs* clock = nullptr;
    const bool* recording = nullptr;
    std::vector<SentFrame> sent;
  };
  class MemoryStorage : public NodeStorage {
   public:
    bool load(std::vector<std::uint8_t>& blob) override;
    bool save(std::span<const std::uint8_t> blob) override;
    std::vector<std::uint8_t> blob;
  };

  void start_from_power_on();
  void run_record(const std::uint8_t* r);
  void arm_fault(const std::uint8_t* r);
  void deliver(const std::uint8_t* r);
  void run_until(TimeUs t);

  CheckingSink sink_;
  MemoryStorage storage_;
  std::unique_ptr<Application> app_;
  personalities::MeasurementControl* measurement_ = nullptr;  // app_'s, when it has one
  std::optional<Node> node_;
  std::optional<NodeSnapshot> node_at_power_on_;
  std::unique_ptr<Application> app_at_power_on_;
  std::vector<std::uint8_t> storage_at_power_on_;
  TimeUs now_ = 0;
  bool recording_ = false;
};

}  // namespace cansim::test
