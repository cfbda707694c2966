// Plants' cost (docs/benchmarks.md "Plants"), a plain main
// that prints figures:
//
//   per block   CPU ns of one plant step per block type: a plant of the block
//               and its input (a new value every 10 ms), stepped 50 s, less
//               the step of the plant of the input alone run just before it
//               (printed as "empty plant");
//   fleet       1,000 sensors (the typical chain of physics_bench, sampled at
//               1 kHz, read every 10 ms staggered as the loop does) reading
//               100 plants (the closed-loop vessel: compressor, 2 l tank,
//               vent; 1 ms step; a controller's two commands every 50 ms),
//               against the same 1,000 sensors on today's open-loop process
//               (setpoint response + pulsation), rounds interleaved on the
//               same host: CPU ms per simulated second, the median of the
//               rounds, and the operator new calls on the step path (must be 0).
//
//   ./build/bench/plant_bench [ROUNDS]   (default 7)
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "physics/plant.hpp"
#include "support/counting_new.hpp"
#include "typical_sensor.hpp"

using namespace cansim::physics;
using cansim::test::g_allocations;

namespace {

constexpr TimeUs kMs = 1000;
constexpr TimeUs kSecond = 1000 * kMs;

double cpu_ns() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e9 + double(ts.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

PlantSignal ref(const char* name) { return PlantSignal{name, 0.0, ""}; }

// A plant of input u (set every 10 ms, as a command arrives) and `block` reading it.
PlantSpec one_block(const char* name, std::optional<BlockParams> block) {
  PlantSpec s;
  s.name = name;
  PlantInputSpec u;
  u.name = "u";
  u.initial = 2e5;
  s.inputs.push_back(u);
  if (block) s.blocks.push_back({"b", *block, std::nullopt, ""});
  return s;
}

struct BlockCase {
  const char* name;
  std::optional<BlockParams> block;
};

std::vector<BlockCase> block_cases() {
  GasVolumeBlock volume;
  volume.volume_m3 = 2e-3;
  volume.initial_pressure_pa = 4e5;
  volume.inflow = {PlantSignal::value(1e-3)};
  volume.outflow = {PlantSignal::value(5e-4)};
  ValveBlock valve;
  valve.upstream = ref("u");
  PumpBlock pump;
  pump.curve = {{0.0, 1e-3}, {5e5, 5e-4}, {1e6, 0.0}};
  pump.outlet = ref("u");
  LineBlock line{ref("u"), 0.05};
  HeatSourceBlock heat;
  heat.power = ref("u");
  IntegratorBlock integrator{ref("u"), 1.0, -1e9, 1e9, 0.0};
  return {{"empty plant (input only)", std::nullopt},
          {"gas_volume", volume},
          {"valve (Kv, gas)", valve},
          {"pump (with curve)", pump},
          {"line (50 ms)", line},
          {"heat_source", heat},
          {"gain", GainBlock{ref("u"), 2.0}},
          {"offset", OffsetBlock{ref("u"), 1.0}},
          {"sum", SumBlock{{ref("u"), PlantSignal::value(1.0)}, {}}},
          {"lag", LagBlock{ref("u"), 0.5, 1.0}},
          {"second_order", SecondOrderBlock{ref("u"), 2.0, 0.4, 1.0}},
          {"integrator", integrator},
          {"rate_limit", RateLimitBlock{ref("u"), 1e5, 1e5}},
          {"saturation", SaturationBlock{ref("u"), 1.5e5, 2.5e5}},
          {"dead_time (50 ms)", DeadTimeBlock{ref("u"), 0.05}},
          {"table", TableBlock{ref("u"), {{1e5, 0.0}, {2e5, 1.0}, {3e5, 0.5}}}}};
}

// CPU ns per step of a plant, stepped `seconds` simulated seconds.
double ns_per_step(Plant& p, int seconds, long& allocs) {
  TimeUs t = p.time() + p.step_us();
  p.advance_to(t);
  const long a0 = g_allocations.load();
  const double c0 = cpu_ns();
  const TimeUs end = t + seconds * kSecond;
  for (; t <= end; t += 10 * kMs) {  // a new command and a reader every 10 ms
    p.set_input(0, 2e5 + double(t % kSecond), t);
    p.advance_to(t);
  }
  const double c1 = cpu_ns();
  allocs += g_allocations.load() - a0;
  return (c1 - c0) / (seconds * 1000.0);
}

void per_block(int rounds) {
  constexpr int kSeconds = 50;
  std::printf(
      "plant step cost per block (CPU ns per 1 ms step, median of %d rounds of %d simulated s,\n"
      "less the plant of the input alone run just before it)\n",
      rounds, kSeconds);
  std::vector<BlockCase> cases = block_cases();
  std::vector<std::unique_ptr<Plant>> plants;
  for (const BlockCase& c : cases) plants.push_back(std::make_unique<Plant>(one_block(c.name, c.block), 1));
  std::vector<std::vector<double>> ns(cases.size()), net(cases.size());
  long allocs = 0;
  for (int r = 0; r < rounds; ++r)
    for (std::size_t i = 1; i < cases.size(); ++i) {
      const double empty = ns_per_step(*plants[0], kSeconds, allocs);
      const double with = ns_per_step(*plants[i], kSeconds, allocs);
      ns[0].push_back(empty);
      ns[i].push_back(with);
      net[i].push_back(with - empty);
    }
  std::printf("  %-26s %8.1f ns per step\n", cases[0].name, median(ns[0]));
  for (std::size_t i = 1; i < cases.size(); ++i)
    std::printf("  %-26s %8.1f ns per step (%.1f with the input)\n", cases[i].name, median(net[i]), median(ns[i]));
  std::printf("  operator new calls while stepping: %ld\n\n", allocs);
}

// The closed-loop vessel of examples/closed_loop: inputs pump_speed and valve (pushed).
PlantSpec vessel(const std::string& name) {
  PlantSpec s;
  s.name = name;
  for (const char* in : {"pump_speed", "valve"}) {
    PlantInputSpec i;
    i.name = in;
    i.kind = QuantityKind::kFraction;
    i.initial = 0.5;
    s.inputs.push_back(i);
  }
  GasVolumeBlock tank;
  tank.volume_m3 = 2e-3;
  tank.initial_pressure_pa = 3e5;
  tank.inflow = {ref("pump")};
  tank.outflow = {ref("vent")};
  s.blocks.push_back({"tank", tank, std::nullopt, ""});
  PumpBlock pump;
  pump.nominal_flow_kgs = 600.0 / 60000.0 * Medium{}.normal_density();
  pump.speed = ref("pump_speed");
  pump.outlet = ref("tank.pressure");
  s.blocks.push_back({"pump", pump, std::nullopt, ""});
  ValveBlock vent;
  vent.kv = 0.5;
  vent.upstream = ref("tank.pressure");
  vent.opening = ref("valve");
  s.blocks.push_back({"vent", vent, std::nullopt, ""});
  return s;
}

struct Fleet {
  std::unique_ptr<PlantSet> plants;
  std::unique_ptr<PlantSetResolver> resolver;
  std::vector<Sensor> sensors;
  TimeUs sim = 0;
  double acc = 0;
};

Fleet open_loop_fleet(int nodes) {
  Fleet f;
  f.sensors.reserve(nodes);
  for (int i = 0; i < nodes; ++i) f.sensors.push_back(cansim::bench::make_sensor(std::uint64_t(i)));
  return f;
}

Fleet plant_fleet(int nodes, int plant_count) {
  Fleet f;
  std::vector<PlantSpec> specs;
  for (int i = 0; i < plant_count; ++i) specs.push_back(vessel("vessel" + std::to_string(i)));
  f.plants = std::make_unique<PlantSet>(specs, 1);
  f.resolver = std::make_unique<PlantSetResolver>(*f.plants);
  f.sensors.reserve(nodes);
  for (int i = 0; i < nodes; ++i) {
    ProcessSpec process = cansim::bench::typical_process();  // its temperature: the cooling gas volume
    process.pressure = {PlantTermSpec{"vessel" + std::to_string(i % plant_count) + ".tank.pressure", ""}};
    f.sensors.push_back(cansim::bench::make_sensor(std::uint64_t(i), process, f.resolver.get()));
  }
  return f;
}

// One simulated second of the fleet: CPU ms; allocations added to `allocs`.
double run_second(Fleet& f, long& allocs) {
  const int nodes = int(f.sensors.size());
  const long a0 = g_allocations.load();
  const double c0 = cpu_ns();
  for (TimeUs slot = 0; slot < kSecond; slot += kMs) {
    const TimeUs now = f.sim + slot;
    if (f.plants && now % (50 * kMs) == 0)  // the controllers' commands
      for (const auto& p : f.plants->plants()) {
        const double phase = double(now % (10 * kSecond)) / double(10 * kSecond);
        p->set_input(0, 0.6 + 0.2 * phase, now);
        p->set_input(1, 0.4 + 0.1 * phase, now);
      }
    for (int i = int((now / kMs) % 10); i < nodes; i += 10) f.acc += f.sensors[i].read(now).pressure.value;
  }
  const double c1 = cpu_ns();
  allocs += g_allocations.load() - a0;
  f.sim += kSecond;
  return (c1 - c0) / 1e6;
}

void fleets(int rounds) {
  const int nodes = 1000, plant_count = 100;
  Fleet open = open_loop_fleet(nodes), closed = plant_fleet(nodes, plant_count);
  long open_allocs = 0, closed_allocs = 0, warm = 0;
  run_second(open, warm);  // first reads fill the filters
  run_second(closed, warm);
  std::vector<double> open_ms, closed_ms;
  for (int r = 0; r < rounds; ++r) {
    open_ms.push_back(run_second(open, open_allocs));
    closed_ms.push_back(run_second(closed, closed_allocs));
  }
  const double o = median(open_ms), c = median(closed_ms);
  std::printf(
      "1,000 sensors at 1 kHz, read every 10 ms (CPU ms per simulated second, median of %d interleaved rounds)\n",
      rounds);
  std::printf("  open loop (today's process terms)      %8.1f ms   allocations %ld\n", o, open_allocs);
  std::printf("  reading 100 plants (1 ms step)         %8.1f ms   allocations %ld\n", c, closed_allocs);
  std::printf("  difference                             %+8.1f ms (%+.1f %%; the plants replace the pressure terms)\n",
              c - o, 100.0 * (c - o) / o);
  std::printf("  (checksums %.6g %.6g)\n", open.acc, closed.acc);
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::max(1, std::atoi(argv[1])) : 7;
  per_block(rounds);
  fleets(rounds);
  return 0;
}
