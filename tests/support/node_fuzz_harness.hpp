// The machinery of the node fuzz target (fuzz/node_fuzz.cpp), shared with its
// unit test: one node of each shipped profile in faithful and strict mode
// (the variants below), with its application and storage, fed an input of
// a variant byte and (time step, frame) records (the record layout is
// described in fuzz/node_fuzz.cpp). The input's first byte selects the
// variant, so a crash input reproduces alone whatever ran before it.
//
// Each variant's node, application and storage are built and powered on
// once, at time 0, at its first input, run to the boot-up, and snapshotted
// then (Node::snapshot, Application::snapshot, the storage blob). Every
// input starts by restoring all three: the OD values, every service with its
// timers and transfers, the physics with its random state, the armed faults
// and what was stored are then exactly as after the first power-on, whatever
// the inputs before did. So no state leaks from one input into the next
// (node_fuzz_test runs inputs A, B, A and compares every frame the two runs
// of A sent).
#pragma once

#include <cstdint>
#include <iterator>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "config/profile.hpp"
#include "core/node.hpp"
#include "personalities/measurement_control.hpp"
#include "support/memory_storage.hpp"

namespace cansim::test {

// A shipped profile in faithful or strict mode.
struct NodeFuzzVariant {
  const char* name;     // "dps-strict"
  const char* profile;  // profiles/<profile>.yaml
  bool strict;
};
inline constexpr NodeFuzzVariant kNodeFuzzVariants[] = {
    {"generic-404", "generic-404", false},
    {"generic-404-strict", "generic-404", true},
    {"dps", "dps", false},
    {"dps-strict", "dps", true},
    {"p92c", "p92c", false},
    {"p92c-strict", "p92c", true},
    {"gems9000", "gems9000", false},
    {"gems9000-strict", "gems9000", true},
    {"smc", "smc", false},
    {"smc-strict", "smc", true},
    {"cmp", "cmp", false},
    {"cmp-strict", "cmp", true},
};
inline constexpr std::size_t kNodeFuzzVariantCount = std::size(kNodeFuzzVariants);
// The variant an input's first byte selects, and the byte that selects a variant.
inline std::size_t node_fuzz_variant(std::uint8_t selector) { return selector % kNodeFuzzVariantCount; }
// The index of a variant by name (kNodeFuzzVariantCount when unknown).
std::size_t node_fuzz_variant(const std::string& name);

// A variant's profile as the fuzz target runs it: the CiA 404 event checks
// and the vendor supervision every 100 ms and the sensor sampling at 100 Hz /
// 10 Hz (same code paths, a tenth to a hundredth of the work per simulated
// second), prepared by its personality. `profiles` is the profiles folder.
config::Profile node_fuzz_profile(const std::string& profiles, const NodeFuzzVariant& variant);

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
  TimeUs booted_at_ = 0;  // where every input starts: the boot-up after power-on
  bool recording_ = false;
};

// Every variant, each built at its first input: what the fuzz target runs.
class NodeFuzzTarget {
 public:
  explicit NodeFuzzTarget(std::string profiles) : profiles_(std::move(profiles)) {}
  // Byte 0 selects the variant, the rest are its records.
  void run(std::span<const std::uint8_t> input);
  NodeFuzzHarness& harness(std::size_t variant);

 private:
  std::string profiles_;
  std::vector<config::Profile> profile_storage_ = std::vector<config::Profile>(kNodeFuzzVariantCount);
  std::unique_ptr<NodeFuzzHarness> harnesses_[kNodeFuzzVariantCount];
};

}  // namespace cansim::test
