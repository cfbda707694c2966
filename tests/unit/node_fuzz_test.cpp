// The node fuzz target's harness (tests/support/node_fuzz_harness.hpp), for
// every variant (each shipped profile, faithful and strict): every input
// starts from the state after power-on, so an input gives the same frames
// whatever ran before it, and its first byte selects the variant (a crash
// input reproduces alone).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "support/node_fuzz_harness.hpp"

namespace cansim::test {
namespace {

namespace fs = std::filesystem;

struct Input {
  std::string name;
  std::vector<std::uint8_t> bytes;
};

// The committed seed corpus: every service, faults, store and power cycles.
std::vector<Input> seed_corpus() {
  std::vector<Input> inputs;
  for (const auto& f : fs::directory_iterator(fs::path(CANSIM_SOURCE_DIR) / "fuzz" / "corpus")) {
    std::ifstream in(f.path(), std::ios::binary);
    inputs.push_back({f.path().filename().string(), std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {})});
  }
  std::sort(inputs.begin(), inputs.end(), [](const Input& a, const Input& b) { return a.name < b.name; });
  return inputs;
}

class NodeFuzzHarnessTest : public ::testing::TestWithParam<std::size_t> {
 protected:
  const NodeFuzzVariant& variant() const { return kNodeFuzzVariants[GetParam()]; }
  const config::Profile profile = node_fuzz_profile(std::string(CANSIM_SOURCE_DIR) + "/profiles", variant());
  const std::vector<Input> corpus = seed_corpus();

  // What `input` sends when it is the first input of a new harness.
  std::vector<SentFrame> alone(const Input& input) {
    NodeFuzzHarness h(profile);
    h.record_frames(true);
    h.run(input.bytes);
    return h.frames();
  }
};

TEST_P(NodeFuzzHarnessTest, AnInputSendsTheSameFramesAfterAnyOther) {
  ASSERT_GE(corpus.size(), 10u);
  std::vector<std::vector<SentFrame>> reference;
  std::size_t frames = 0;
  for (const Input& a : corpus) {
    reference.push_back(alone(a));
    frames += reference.back().size();
  }
  EXPECT_GT(frames, corpus.size()) << variant().name;
  NodeFuzzHarness shared(profile);
  shared.record_frames(true);
  // A, then every other input B, then A again: forwards and backwards.
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t k = 0; k < corpus.size(); ++k) {
      const std::size_t i = pass == 0 ? k : corpus.size() - 1 - k;
      shared.run(corpus[i].bytes);
      EXPECT_EQ(shared.frames(), reference[i]) << corpus[i].name << " in pass " << pass;
    }
  }
}

// An input that leaves the node with changed values, a stored blob, an armed
// fault and an open SDO transfer does not change the next one.
TEST_P(NodeFuzzHarnessTest, ALeftoverOfOneInputDoesNotReachTheNext) {
  auto record = [](std::uint16_t step_10us, std::uint8_t target, std::uint8_t param, std::uint8_t dlc,
                   std::initializer_list<std::uint8_t> data) {
    std::vector<std::uint8_t> r = {std::uint8_t(step_10us), std::uint8_t(step_10us >> 8), target, param, dlc};
    r.insert(r.end(), data.begin(), data.end());
    r.resize(13, 0);
    return r;
  };
  std::vector<std::uint8_t> messy;
  for (const auto& r : {record(100, 0, 0, 2, {0x01, 0x00}),                                  // NMT start all
                        record(100, 2, 0, 8, {0x2B, 0x17, 0x10, 0x00, 0x64, 0x00}),          // heartbeat 100 ms
                        record(100, 2, 0, 8, {0x23, 0x10, 0x10, 0x01, 's', 'a', 'v', 'e'}),  // store all
                        record(100, 14, 3, 0, {0, 0, 0, 0}),                                 // heartbeat stop
                        record(100, 2, 0, 8, {0x40, 0x08, 0x10, 0x00})})                     // upload left open
    messy.insert(messy.end(), r.begin(), r.end());
  Input power_cycle{"power cycle, then 1.8 s of SYNCs", {}};  // shows stored values, e.g. 0x1017
  for (const auto& r :
       {record(100, 15, 0, 0, {}), record(60000, 1, 0, 0, {}), record(60000, 1, 0, 0, {}), record(60000, 1, 0, 0, {})})
    power_cycle.bytes.insert(power_cycle.bytes.end(), r.begin(), r.end());
  for (const Input& probe : {corpus.front(), power_cycle}) {
    NodeFuzzHarness h(profile);
    h.record_frames(true);
    h.run(messy);
    EXPECT_FALSE(h.frames().empty());
    h.run(probe.bytes);
    EXPECT_EQ(h.frames(), alone(probe)) << probe.name;
  }
}

INSTANTIATE_TEST_SUITE_P(Variants, NodeFuzzHarnessTest, ::testing::Range<std::size_t>(0, kNodeFuzzVariantCount),
                         [](const auto& info) {
                           std::string n = kNodeFuzzVariants[info.param].name;
                           for (char& c : n)
                             if (c == '-') c = '_';
                           return n;
                         });

// Byte 0 of an input picks the variant (modulo the count): an SDO upload of
// 0x1000 is answered by that variant's node, on its node-ID.
TEST(NodeFuzzTarget, TheFirstByteSelectsTheVariant) {
  NodeFuzzTarget target(std::string(CANSIM_SOURCE_DIR) + "/profiles");
  for (std::size_t v = 0; v < 2 * kNodeFuzzVariantCount; v += 5) {
    const std::size_t variant = v % kNodeFuzzVariantCount;
    NodeFuzzHarness& h = target.harness(variant);
    h.record_frames(true);
    const std::vector<std::uint8_t> input = {std::uint8_t(v), 100, 0, 2, 0, 8, 0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0};
    target.run(input);
    const config::Profile p =
        node_fuzz_profile(std::string(CANSIM_SOURCE_DIR) + "/profiles", kNodeFuzzVariants[variant]);
    ASSERT_FALSE(h.frames().empty()) << kNodeFuzzVariants[variant].name;
    EXPECT_EQ(h.frames().back().frame.id, 0x580u + p.node_id) << kNodeFuzzVariants[variant].name;
  }
}

}  // namespace
}  // namespace cansim::test
