// libFuzzer target: one generic-404 node (with its personality) fed a
// sequence of (time step, frame) records. Every service sees traffic: NMT,
// SYNC, SDO, LSS, RPDO, RTR on TPDOs, heartbeats of other nodes, raw IDs, and
// power cycles. Must never crash, trip ASan/UBSan, spin without advancing
// time, or send an invalid frame.
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
// Speed (scripts/fuzz-run gives it 60 s in CI): the profile is loaded and
// prepared once, with the CiA 404 event checks every 100 ms instead of 10 ms
// and the sensor sampling at 100 Hz / 10 Hz instead of 1 kHz / 100 Hz (same
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
// What an input costs (perf, README "Fuzzing"): its records, about 5 us each
// with ASan and UBSan, and libFuzzer's bookkeeping per edge it touched.
// libstdc++'s templates are left out of the coverage (fuzz/coverage-ignore.txt)
// and the node's layers are built without compare tracing
// (fuzz/CMakeLists.txt). scripts/fuzz-run runs this target two thirds of
// its time with edge coverage only (-use_counters=0: short inputs, about
// 35,000/s) and a third with hit counts (the deeper loop iterations, about
// 12,000/s): 1.6 M inputs in 60 s on the 2-core host.
#include <cstddef>
#include <cstdint>
#include <span>

#include "support/node_fuzz_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const cansim::config::Profile profile = cansim::test::node_fuzz_profile(CANSIM_FUZZ_PROFILE);
  static cansim::test::NodeFuzzHarness harness(profile);
  harness.run(std::span<const std::uint8_t>(data, size));
  return 0;
}
