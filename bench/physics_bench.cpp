// Physics layer benchmarks: cost per value through the full chain, and the fleet cost.
//
//   BM_ProcessEval       one ProcessModel::at() of a composed process
//   BM_ChainPerSample    sensor read every 1 ms: one new sample per channel per read
//                        (ns_per_value = CPU time / channel samples)
//   BM_ChainRead10ms     read every 10 ms: catch-up of 10 samples per channel
//   BM_Fleet1000         1,000 nodes sampled at 1 kHz, each read every 10 ms; one iteration
//                        = one simulated second, so the reported time (ms) IS the CPU cost
//                        per simulated second. allocs counts operator new calls (must be 0).
#include <benchmark/benchmark.h>

#include <vector>

#include "typical_sensor.hpp"
#include "support/counting_new.hpp"  // the allocation counter the physics tests use

using namespace cansim::physics;
using cansim::bench::make_sensor;
using cansim::bench::typical_process;
using cansim::test::g_allocations;

namespace {

constexpr TimeUs kMs = 1000;

void BM_ProcessEval(benchmark::State& state) {
  ProcessModel m(typical_process(), 1);
  double t = 0, acc = 0;
  for (auto _ : state) {
    t += 0.001;
    acc += m.at(t).pressure_pa;
  }
  benchmark::DoNotOptimize(acc);
  state.counters["ns_per_eval"] = benchmark::Counter(static_cast<double>(state.iterations()),
                                                     benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ProcessEval);

void chain_bench(benchmark::State& state, TimeUs read_period) {
  Sensor s = make_sensor(1);
  TimeUs t = 0;
  double acc = 0;
  std::int64_t values = 0;
  const long a0 = g_allocations.load();
  for (auto _ : state) {
    t += read_period;
    const auto& r = s.read(t);
    acc += r.pressure.value;
    values += 2 * (read_period / kMs);  // new samples on both channels
  }
  const long allocs = g_allocations.load() - a0;  // before the counters map allocates
  benchmark::DoNotOptimize(acc);
  state.counters["ns_per_value"] =
      benchmark::Counter(static_cast<double>(values), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["allocs"] = static_cast<double>(allocs);
}
void BM_ChainPerSample(benchmark::State& state) { chain_bench(state, 1 * kMs); }
void BM_ChainRead10ms(benchmark::State& state) { chain_bench(state, 10 * kMs); }
BENCHMARK(BM_ChainPerSample);
BENCHMARK(BM_ChainRead10ms);

void BM_Fleet1000(benchmark::State& state) {
  const int nodes = 1000;
  std::vector<Sensor> fleet;
  fleet.reserve(nodes);
  for (int i = 0; i < nodes; ++i) fleet.push_back(make_sensor(static_cast<std::uint64_t>(i)));
  // Stagger the reads over the 10 ms period like an event loop would.
  TimeUs sim = 0;
  double acc = 0;
  long allocs = 0;
  for (auto _ : state) {
    const long a0 = g_allocations.load();
    for (TimeUs slot = 0; slot < 1000 * kMs; slot += kMs) {  // one simulated second in 1 ms ticks
      const TimeUs now = sim + slot;
      // nodes whose 10 ms read falls into this tick
      for (int i = static_cast<int>((now / kMs) % 10); i < nodes; i += 10) acc += fleet[i].read(now).pressure.value;
    }
    sim += 1000 * kMs;
    allocs += g_allocations.load() - a0;
  }
  benchmark::DoNotOptimize(acc);
  state.counters["sim_s"] = static_cast<double>(state.iterations());
  state.counters["reads_per_sim_s"] = nodes * 100.0;
  state.counters["allocs"] = static_cast<double>(allocs);
}
BENCHMARK(BM_Fleet1000)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

}  // namespace

BENCHMARK_MAIN();
