// Loop + core throughput with a null transport (no sockets): CPU ns per frame
// for SDO request/response traffic, the cost of a fleet of nodes with a 10 ms
// TPDO and a 100 ms heartbeat per simulated second, and bytes per node.
//
//   ./build/bench/loop_bench [nodes=1000] [simulated_seconds=5]
//
// With `timed`: what the timed bus model costs against ideal buses (the full
// chain, fake clock: 1 Mbit/s buses of 127 nodes with TPDO1 every 20 ms and a
// 100 ms heartbeat, ~65 % load; 5 runs each, interleaved), paced by the loop
// (a wake-up per frame end) and handed to a transport that paces itself (as
// SO_TXTIME with the ETF qdisc: the burst handed over in batches), then the
// loop's wake-up lateness with a real timer (timerfd, absolute deadlines) on
// that fleet for the same number of real seconds.
//
//   ./build/bench/loop_bench [nodes=127] [seconds=5] timed
#include <malloc.h>

#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include <algorithm>

#include "config/fleet.hpp"
#include "io/event_loop.hpp"
#include "io/loop_core.hpp"
#include "personalities/registry.hpp"

using namespace cansim;

namespace {

double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + double(ts.tv_nsec) * 1e-9;
}

CanFrame frame(std::uint32_t id, std::initializer_list<std::uint8_t> b) { return CanFrame::make(id, b); }

// Nodes spread over buses of 127 (node-IDs 1..127 on each), as on real CAN.
struct Fleet {
  io::LoopCore core;
  io::NullTransport tx;
  io::BusId bus = 0;
  std::vector<io::BusId> buses;
  std::vector<io::NodeRef> nodes;

  // rate: CiA 305 bit-rate index of the buses and nodes (3: 250 kbit/s);
  // paced: the transport paces a timed bus itself (kernel pacing).
  Fleet(config::Profile& profile, int count, bool with_app = true, std::uint8_t rate = 3,
        io::BusModel model = io::BusModel::kIdeal, bool paced = false) {
    tx.paced = paced;
    for (int i = 0; i < count; ++i) {
      if (i % 127 == 0) {
        buses.push_back(core.add_bus("null" + std::to_string(i / 127), tx, rate));
        core.set_bus_model(buses.back(), model);
      }
      NodeSetup s = config::node_setup(profile, std::uint8_t(1 + i % 127));
      s.bit_rate_index = rate;
      personalities::NodeContext ctx;
      ctx.index = std::uint32_t(i);
      ctx.key = "null/bench/" + std::to_string(i);
      nodes.push_back(
          core.add_node(buses.back(), s, with_app ? personalities::make_application(profile, ctx) : nullptr));
    }
    bus = buses.front();
    for (io::NodeRef r : nodes) core.power_on(r, 0);
  }
};

config::Profile load_profile() {
  const char* dir = std::getenv("CANSIM_SOURCE_DIR");
  std::string path = std::string(dir ? dir : CANSIM_SOURCE_DIR) + "/profiles/generic-404.yaml";
  config::Profile p = config::load_profile(path);
  return p;
}

// SDO upload requests from the wire and the responses, 127 distinct nodes.
void bench_sdo(config::Profile& profile) {
  Fleet f(profile, 127);
  const int rounds = 2000;
  std::uint64_t out_before = f.tx.frames;
  double t0 = cpu_seconds();
  TimeUs now = 1;
  for (int r = 0; r < rounds; ++r)
    for (int id = 1; id <= 127; ++id) {
      f.core.receive(f.bus, frame(0x600 + id, {0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}), now);
      now += 10;
    }
  double cpu = cpu_seconds() - t0;
  std::uint64_t frames = std::uint64_t(rounds) * 127 + (f.tx.frames - out_before);
  std::printf("SDO expedited upload, 127 nodes: %.0f ns CPU per frame (in + out), %.2f M frames/s per core\n",
              cpu * 1e9 / double(frames), double(frames) / cpu / 1e6);
}

// N nodes operational with TPDO1 every 10 ms and a 100 ms heartbeat.
void bench_fleet(config::Profile& profile, int count, int seconds, bool with_app) {
  struct mallinfo2 before = mallinfo2();
  Fleet f(profile, count, with_app);
  struct mallinfo2 after = mallinfo2();
  std::uint8_t et[2] = {10, 0}, hb[2] = {100, 0};
  for (io::NodeRef r : f.nodes) {
    f.core.node(r).write(0x1800, 5, et, 0);
    f.core.node(r).write(0x1017, 0, hb, 0);
    f.core.refresh(r);
  }
  for (io::BusId b : f.buses) f.core.receive(b, frame(0x000, {0x01, 0x00}), 0);
  f.core.run_until(ms(1000));  // settle
  std::uint64_t out0 = f.tx.frames, wake0 = f.core.stats().wakeups, local0 = f.core.stats().local_deliveries;
  double t0 = cpu_seconds();
  f.core.run_until(ms(1000) + ms(1000) * seconds);
  double cpu = cpu_seconds() - t0;
  double frames = double(f.tx.frames - out0);
  double cpu_per_sim_s = cpu / seconds;
  std::printf(
      "%d nodes on %zu buses, %s, TPDO 10 ms + heartbeat 100 ms: %.0f frames/s simulated, %.3f s CPU per "
      "simulated s\n",
      count, f.buses.size(), with_app ? "with the personality application" : "core only (no application)",
      frames / seconds, cpu_per_sim_s);
  std::printf("  %.0f ns CPU per frame sent, %llu node wake-ups, %llu local deliveries\n", cpu * 1e9 / frames,
              (unsigned long long)(f.core.stats().wakeups - wake0),
              (unsigned long long)(f.core.stats().local_deliveries - local0));
  std::printf("  one core sustains about %.0f such nodes in real time (%.0f frames/s)\n", count / cpu_per_sim_s,
              frames / seconds / cpu_per_sim_s);
  std::size_t heap = after.uordblks - before.uordblks;
  std::printf("  memory: Node::memory_bytes() = %zu, heap per node incl. application, slot, dispatch = %zu bytes\n",
              f.core.node(f.nodes[0]).memory_bytes(), heap / std::size_t(count));
}

// Operational, TPDO1 every `tpdo_ms`, heartbeat every 100 ms.
void start_fleet(Fleet& f, std::uint8_t tpdo_ms) {
  std::uint8_t et[2] = {tpdo_ms, 0}, hb[2] = {100, 0};
  for (io::NodeRef r : f.nodes) {
    f.core.node(r).write(0x1800, 5, et, 0);
    f.core.node(r).write(0x1017, 0, hb, 0);
    f.core.refresh(r);
  }
  for (io::BusId b : f.buses) f.core.receive(b, frame(0x000, {0x01, 0x00}), 0);
}

struct CostRun {
  double ns_per_frame;
  double frames_per_s;
  std::uint64_t passes;  // loop passes (run_due)
  io::BusLoad load;
};

// The three ways a bus can run.
enum class Setup { kIdeal, kLoopPaced, kKernelPaced };
const char* name(Setup s) { return s == Setup::kIdeal ? "ideal" : s == Setup::kLoopPaced ? "timed" : "paced"; }

Fleet make_fleet(config::Profile& profile, int count, Setup setup) {
  return Fleet(profile, count, true, 0, setup == Setup::kIdeal ? io::BusModel::kIdeal : io::BusModel::kTimed,
               setup == Setup::kKernelPaced);
}

CostRun run_cost(config::Profile& profile, int count, int seconds, Setup setup) {
  Fleet f = make_fleet(profile, count, setup);
  start_fleet(f, 20);
  f.core.run_until(ms(1000));
  std::uint64_t out0 = f.tx.frames, pass0 = f.core.stats().passes;
  double t0 = cpu_seconds();
  f.core.run_until(ms(1000) + ms(1000) * seconds);
  double cpu = cpu_seconds() - t0;
  double frames = double(f.tx.frames - out0);
  return {cpu * 1e9 / frames, frames / seconds, f.core.stats().passes - pass0, f.core.bus_load(f.bus)};
}

// Timed (loop- and kernel-paced) against ideal, full chain, 5 runs each,
// interleaved (the order rotating): the host's other work hits all alike.
// Best and median.
void bench_timed_cost(config::Profile& profile, int count, int seconds) {
  constexpr int kRuns = 5;
  constexpr Setup kSetups[] = {Setup::kIdeal, Setup::kLoopPaced, Setup::kKernelPaced};
  std::vector<CostRun> runs[3];
  for (int round = 0; round < kRuns; ++round)
    for (int k = 0; k < 3; ++k) {
      const int m = (round + k) % 3;
      CostRun r = run_cost(profile, count, seconds, kSetups[m]);
      std::printf("  run %d %-5s: %.0f ns CPU per frame sent (%.0f frames/s simulated, %.0f loop passes/s)\n",
                  round + 1, name(kSetups[m]), r.ns_per_frame, r.frames_per_s, double(r.passes) / seconds);
      runs[m].push_back(r);
    }
  for (auto& v : runs)
    std::sort(v.begin(), v.end(), [](const CostRun& a, const CostRun& b) { return a.ns_per_frame < b.ns_per_frame; });
  std::printf("%d nodes on %d bus(es) at 1 Mbit/s, TPDO1 20 ms + heartbeat 100 ms, full chain, %d runs each:\n", count,
              (count + 126) / 127, kRuns);
  const CostRun& ideal = runs[0][0];
  const double ideal_median = runs[0][kRuns / 2].ns_per_frame;
  for (int m = 1; m < 3; ++m) {
    const CostRun& best = runs[m][0];
    const double median = runs[m][kRuns / 2].ns_per_frame;
    std::printf(
        "  %s: best %.0f ns against ideal's %.0f ns CPU per frame sent: %+.1f %%; median %.0f against %.0f: "
        "%+.1f %%\n",
        m == 1 ? "timed, loop-paced  " : "timed, kernel-paced", best.ns_per_frame, ideal.ns_per_frame,
        (best.ns_per_frame / ideal.ns_per_frame - 1) * 100, median, ideal_median, (median / ideal_median - 1) * 100);
    const io::BusLoad& l = best.load;
    std::printf(
        "    first bus: carried %.1f %% of 1 Mbit/s over 1 s, queueing delay p50 %lld us, p99 %lld us, max "
        "%lld us, slip max %lld us, %llu dropped\n",
        l.carried_1s * 100, (long long)l.delay_p50, (long long)l.delay_p99, (long long)l.delay_max,
        (long long)l.slip_max, (unsigned long long)l.dropped);
  }
}

// The daemon's loop shape on a real clock: one absolute timerfd armed at the
// core's next deadline, run_due at each wake-up. Lateness: how long after
// its deadline the loop was running again.
void bench_wakeup_lateness(config::Profile& profile, int count, int seconds, Setup setup) {
  Fleet f = make_fleet(profile, count, setup);
  start_fleet(f, 20);
  io::EventLoop loop;
  if (!loop.open()) {
    std::fprintf(stderr, "event loop: %s\n", loop.error().c_str());
    std::exit(1);
  }
  const TimeUs epoch = io::monotonic_now();
  std::vector<TimeUs> late;
  late.reserve(std::size_t(seconds) * 200000);
  const TimeUs end = TimeUs(seconds) * 1'000'000;
  double cpu0 = cpu_seconds();
  std::uint64_t out0 = f.tx.frames;
  TimeUs armed = kNever;
  for (;;) {
    const TimeUs now = io::monotonic_now() - epoch;
    if (armed != kNever && now >= armed) late.push_back(now - armed);
    if (now >= end) break;
    f.core.run_due(now);
    armed = f.core.next_deadline();
    loop.arm_timer(armed + epoch);
    bool timer = false;
    int signal = 0;
    loop.wait(-1, timer, signal);
  }
  double cpu = cpu_seconds() - cpu0;
  std::sort(late.begin(), late.end());
  auto pct = [&](double p) { return late.empty() ? 0LL : (long long)late[std::size_t(p * double(late.size() - 1))]; };
  std::uint64_t dropped = 0, queued = 0;
  for (io::BusId b : f.buses) {
    dropped += f.core.bus_load(b).dropped;
    queued += f.core.bus_load(b).queued;
  }
  std::printf(
      "  %-5s %d nodes: %zu wake-ups/s, lateness p50 %lld us, p99 %lld us, max %lld us; %.0f frames/s "
      "(%llu queued at the end, %llu dropped), %.1f %% of a core\n",
      name(setup), count, late.size() / std::size_t(seconds), pct(0.5), pct(0.99),
      late.empty() ? 0LL : (long long)late.back(), double(f.tx.frames - out0) / seconds, (unsigned long long)queued,
      (unsigned long long)dropped, cpu / seconds * 100);
}

}  // namespace

int main(int argc, char** argv) {
  int count = argc > 1 ? std::atoi(argv[1]) : 1000;
  int seconds = argc > 2 ? std::atoi(argv[2]) : 5;
  config::Profile profile = load_profile();
  if (argc > 3 && std::string(argv[3]) == "timed") {
    bench_timed_cost(profile, count, seconds);
    std::printf("wake-up lateness, real timer, %d s each:\n", seconds);
    for (Setup setup : {Setup::kIdeal, Setup::kLoopPaced, Setup::kKernelPaced})
      bench_wakeup_lateness(profile, count, seconds, setup);
    return 0;
  }
  bench_sdo(profile);
  bench_fleet(profile, count, seconds, false);
  bench_fleet(profile, count, seconds, true);
  return 0;
}
