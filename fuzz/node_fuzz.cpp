// libFuzzer target: one node of every shipped profile, each in faithful and
// strict mode (12 variants, tests/support/node_fuzz_harness.hpp), with its
// personality, fed a sequence of (time step, frame) records. Every service
// sees traffic: NMT, SYNC, SDO, LSS, RPDO, RTR on TPDOs, heartbeats of other
// nodes, raw IDs, and power cycles. Must never crash, trip ASan/UBSan, spin
// without advancing time, or send an invalid frame.
//
// Byte 0 of an input selects the variant (its value modulo 12, in the order
// of kNodeFuzzVariants), so every input reproduces alone. With
// CANSIM_NODE_FUZZ_VARIANT=<name> (scripts/fuzz-run runs each variant so)
// the mutator keeps byte 0 on that variant: the run fuzzes one personality
// and its crash inputs still select it. Then come the records.
//
// Record layout (13 bytes; a shorter tail is ignored):
//   b0-1  time step before the frame, little-endian, in 10 us units (< 656 ms)
//   b2    bits 0-3 target: 0 NMT, 1 SYNC, 2 SDO request, 3 LSS, 4 RPDO1,
//         5 TPDO1..4 (b3 & 3), 6 heartbeat of node b3, 7 raw 11-bit id
//         (b3 | (b2 >> 4 & 7) << 8), 8 SDO with any node-ID b3, 9 EMCY,
//         14 arm a communication fault (kind b3 % 6 from silent..sdo_block_drop,
//         duration b5-6 ms (0: until the end of the input), sdo delay b7 ms,
//         drop every b8 % 5 segments, drop probability b9 / 255),
//         15 power cycle; bit 7 RTR
//   b3    parameter of the target
//   b4    DLC (values above 8 are clamped to 8)
//   b5-12 data bytes
// fuzz/make_seeds.py writes the seed corpus in this format.
//
// Speed (scripts/fuzz-run gives each variant 15 s in CI): each profile is
// loaded and prepared once, with the CiA 404 event checks and the vendor
// supervision every 100 ms and the sensor sampling at 100 Hz / 10 Hz (same
// code paths, a tenth of the physics work per simulated second), and the run
// ends with the last record unless an SDO transfer is still open, which then
// runs into its timeout. The node, its application (physics, armed faults, random
// state) and storage are built and powered on once; each input starts from
// snapshots of all three taken right after that power-on
// (tests/support/node_fuzz_harness.hpp): plain copies, about 5 us with the
// sanitizers, where building a node and powering it on cost about 300 us,
// more than the records of a typical input. Restoring all three means no
// state leaks from one input into the next, so a crash input reproduces when
// run alone (node_fuzz_test runs inputs A, B, A and compares every frame of
// the two A runs). The code that builds the node runs once, before the first
// input, so libFuzzer's `cov` no longer counts it.
//
// What an input costs (perf, docs/fuzzing.md): its records, about 5 us each
// with ASan and UBSan, and libFuzzer's bookkeeping per edge it touched.
// libstdc++'s templates are left out of the coverage (fuzz/coverage-ignore.txt)
// and the node's layers are built without compare tracing
// (fuzz/CMakeLists.txt). scripts/fuzz-run runs this target two thirds of
// its time with edge coverage only (-use_counters=0: short inputs, about
// 35,000/s) and a third with hit counts (the deeper loop iterations, about
// 12,000/s): 1.6 M inputs in 60 s on the 2-core host for generic-404
// (docs/fuzzing.md has every variant's figures).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <string>

#include "support/node_fuzz_harness.hpp"

namespace {
int pinned_variant = -1;  // CANSIM_NODE_FUZZ_VARIANT
}

extern "C" size_t LLVMFuzzerMutate(std::uint8_t* data, size_t size, size_t max_size);

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (std::getenv("CANSIM_NODE_FUZZ_LIST")) {  // scripts/fuzz-run: the variants, in selector order
    for (const cansim::test::NodeFuzzVariant& v : cansim::test::kNodeFuzzVariants) std::printf("%s\n", v.name);
    std::exit(0);
  }
  if (const char* name = std::getenv("CANSIM_NODE_FUZZ_VARIANT")) {
    const std::size_t v = cansim::test::node_fuzz_variant(std::string(name));
    if (v == cansim::test::kNodeFuzzVariantCount) std::abort();  // a typo would fuzz the wrong node
    pinned_variant = int(v);
  }
  return 0;
}

extern "C" size_t LLVMFuzzerCustomMutator(std::uint8_t* data, size_t size, size_t max_size, unsigned) {
  size = LLVMFuzzerMutate(data, size, max_size);
  if (pinned_variant >= 0 && size > 0) data[0] = std::uint8_t(pinned_variant);
  return size;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static cansim::test::NodeFuzzTarget target(CANSIM_FUZZ_PROFILES);
  target.run(std::span<const std::uint8_t>(data, size));
  return 0;
}
