// Does the loop notice its controllers? One process: the loop thread runs the
// daemon's loop (io::EventLoop with its absolute timerfd, the loop core, the
// control service and its endpoints on a private socket, serviced after every
// pass as in Daemon::run) over a fleet of generic-404 nodes (100 ms heartbeat,
// TPDO1 every 10 ms, operational) built as the daemon builds them
// (test::ControlFleet), with a transport that only counts frames. Client
// threads call the control API over their own sd-bus connections.
//
// After a 2 s warm-up, A (no client connected) and B (CLIENTS threads making
// RATE calls/s in all: Read 0x1017, Get Pressure, Step pressure, ListFaults
// on random nodes; plus one probe thread stepping node 0's pressure to 2 / 8
// bar every 200 ms, at a random phase of the 10 ms PDO period) alternate in
// 2 s blocks, SECONDS of each in all, so that
// whatever else the host runs weighs on both alike. Clients connect at the
// start of each B block and disconnect before its end (connection churn is
// counted in B, as with cansimctl's one connection per command).
//
// The daemon sends what the nodes produced before it serves the control calls
// of a pass, and what the calls caused after them (sendmmsg at flush,
// Daemon::run), so frames are timestamped at those two flushes. Heartbeat period error: |interval − 100 ms| between
// consecutive heartbeats of a node. set->PDO: the flush time of node 0's
// first TPDO1 within 0.1 bar of the new value, minus the time Step returned
// in the probe thread (negative when the event PDO left before the client
// read the reply).
//
//   ./build/bench/control_bench [NODES=1000] [SECONDS=10] [RATE=1000] [CLIENTS=4] [pin]
//
// pin: the loop thread alone on the last CPU and the client threads on the
// others, as a bench machine would run its simulator beside the test
// program (CPUAffinity=); without it they share every CPU.
//
// Prints figures, asserts nothing. Loop CPU: CLOCK_THREAD_CPUTIME_ID of the
// loop thread, as a share of wall time (read three times per pass for the
// split between the nodes, the control endpoints and the rest: that costs
// about 1 µs per pass, so B, with more passes, pays a little more of it).
#include <pthread.h>
#include <sys/resource.h>
#include <systemd/sd-bus.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "control/endpoints.hpp"
#include "control/service.hpp"
#include "io/can_interface.hpp"
#include "io/event_loop.hpp"
#include "support/control_fleet.hpp"

using namespace cansim;

namespace {

constexpr TimeUs kHeartbeatUs = 100'000;
constexpr std::uint16_t kHeartbeatMs = 100;
constexpr std::uint16_t kTpdoMs = 10;
constexpr TimeUs kWarmUpUs = 2'000'000;
constexpr TimeUs kBoundaryOffsetUs = 55'000;  // blocks start between heartbeat and TPDO deadlines
constexpr TimeUs kBlockUs = 2'000'000;        // A / B alternate in blocks of this length
constexpr TimeUs kDisconnectUs = 30'000;      // clients leave this long before a B block ends
constexpr TimeUs kProbePeriodUs = 200'000;
constexpr int kNodesPerBus = 127;
constexpr int kHistogramUs = 50'000;  // period error histogram, 1 µs buckets

// User-space CPU of the calling thread (the rest of its CPU is the kernel's,
// which a VM inflates: timer and wake-up IPIs exit to the hypervisor).
TimeUs thread_user_us() {
  rusage ru;
  getrusage(RUSAGE_THREAD, &ru);
  return TimeUs(ru.ru_utime.tv_sec) * 1'000'000 + ru.ru_utime.tv_usec;
}

TimeUs thread_cpu_us() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return TimeUs(ts.tv_sec) * 1'000'000 + ts.tv_nsec / 1000;
}

void sleep_until(TimeUs mono_us) {
  timespec ts{time_t(mono_us / 1'000'000), long(mono_us % 1'000'000) * 1000};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// |heartbeat period − 100 ms| over every node's consecutive beats.
struct PeriodError {
  std::uint64_t beats = 0;
  double sum = 0;
  TimeUs max = 0;
  std::vector<std::uint32_t> histogram = std::vector<std::uint32_t>(kHistogramUs + 1);
  void add(TimeUs err) {
    ++beats;
    sum += double(err);
    max = std::max(max, err);
    ++histogram[std::size_t(std::min<TimeUs>(err, kHistogramUs))];
  }
  double mean() const { return beats ? sum / double(beats) : 0; }
  TimeUs percentile(double p) const {
    const std::uint64_t want = std::max<std::uint64_t>(1, std::uint64_t(std::ceil(p * double(beats))));
    std::uint64_t seen = 0;
    for (std::size_t i = 0; i < histogram.size(); ++i)
      if ((seen += histogram[i]) >= want) return TimeUs(i);
    return 0;
  }
};

// What the loop thread measures per phase (0: A, 1: B), summed over blocks,
// and per block. Touched by the loop thread only; main reads it after the
// loop ended.
struct Block {
  TimeUs wall = 0, cpu = 0;
  std::uint64_t beats = 0;
  double error_sum = 0;
};
struct LoopPhase {
  TimeUs wall = 0, cpu = 0, user = 0;
  std::uint64_t frames = 0, passes = 0, timer_wakeups = 0, rearms = 0, control_due = 0;
  double lateness_sum = 0;  // timer wake-up − armed deadline
  TimeUs lateness_max = 0;
  TimeUs pass_max = 0;                    // longest pass: run_due + process()
  TimeUs in_run_due = 0, in_process = 0;  // thread CPU in the core's pass / in the control endpoints
  PeriodError hb;
};

// Node 0's TPDO1 value as the loop thread sees it, for the probe thread.
struct Probe {
  std::mutex mutex;
  bool armed = false;
  float target = 0;
  TimeUs pdo_time = 0;   // flush time of the first TPDO1 within 0.1 bar of target
  TimeUs pdo_pass = 0;   // the start of the pass that sent it
  float last_value = 0;  // the last TPDO1 of node 0 and its flush time (diagnostics)
  TimeUs last_time = 0;
};

struct Shared {
  int block = -1;  // -1: warm-up; even blocks A, odd blocks B; == blocks: done
  int phase() const { return block >= 0 && block < int(blocks.size()) ? block % 2 : -1; }
  std::uint64_t frames = 0;
  std::vector<TimeUs> last_beat;                  // per bus * 128 + node-ID: flush time of the last heartbeat
  std::vector<std::vector<std::uint32_t>> beats;  // per bus: heartbeats waiting for the flush
  std::vector<std::uint32_t> queued;              // per bus: frames waiting for the flush
  TimeUs pass_start = 0;
  bool probe_seen = false;  // a matching TPDO1 in this pass
  bool node0_sent = false;  // a TPDO1 of node 0 in this pass
  float node0_value = 0;
  std::uint32_t probe_cob = 0;
  Probe probe;
  LoopPhase phases[2];
  std::vector<Block> blocks;
};

void flush_bus(Shared& s, std::uint32_t bus, TimeUs mono, TimeUs pass_start);

// The wire of one bus: counts frames, notes heartbeats and node 0's TPDO1
// (bus 0) for the flush. Runs on the loop thread, inside the core's pass.
// As CanInterface does, a full sendmmsg batch leaves at once.
class CountingTransport : public io::Transport {
 public:
  CountingTransport(Shared& s, std::uint32_t bus) : s_(s), bus_(bus) {}
  void transmit(const CanFrame& f) override {
    ++s_.frames;
    if ((f.id & ~0x7Fu) == 0x700 && f.dlc == 1 && f.data[0] != 0x00) {  // heartbeat, not boot-up
      s_.beats[bus_].push_back(bus_ * 128 + (f.id & 0x7F));             // capacity reserved: no allocation
    } else if (bus_ == 0 && f.id == s_.probe_cob && f.dlc >= 4) {
      float v;
      std::memcpy(&v, f.data, 4);  // REAL32 little-endian (x86)
      s_.node0_sent = true, s_.node0_value = v;
      std::lock_guard lock(s_.probe.mutex);
      s_.probe_seen |= s_.probe.armed && s_.probe.pdo_time == 0 && std::fabs(v - s_.probe.target) < 0.1f;
    }
    if (++s_.queued[bus_] >= io::CanInterface::kBatch) flush_bus(s_, bus_, io::monotonic_now(), s_.pass_start);
  }

 private:
  Shared& s_;
  std::uint32_t bus_;
};

// sendmmsg of what waits for one bus: its frames leave now.
void flush_bus(Shared& s, std::uint32_t bus, TimeUs mono, TimeUs pass_start) {
  s.queued[bus] = 0;
  const int phase = s.phase();
  for (std::uint32_t slot : s.beats[bus]) {
    TimeUs& last = s.last_beat[slot];
    if (last && phase >= 0 && s.block < int(s.blocks.size())) {
      const TimeUs err = std::llabs(mono - last - kHeartbeatUs);
      s.phases[phase].hb.add(err);
      ++s.blocks[std::size_t(s.block)].beats;
      s.blocks[std::size_t(s.block)].error_sum += double(err);
    }
    last = mono;
  }
  s.beats[bus].clear();
  if (bus == 0 && s.node0_sent) {
    std::lock_guard lock(s.probe.mutex);
    if (s.probe_seen && s.probe.armed && s.probe.pdo_time == 0) s.probe.pdo_time = mono, s.probe.pdo_pass = pass_start;
    s.probe.last_value = s.node0_value, s.probe.last_time = mono;
    s.probe_seen = s.node0_sent = false;
  }
}

// The daemon's flush: what the pass produced leaves now.
void flush(Shared& s, TimeUs mono, TimeUs pass_start) {
  for (std::uint32_t bus = 0; bus < s.queued.size(); ++bus) flush_bus(s, bus, mono, pass_start);
}

std::string fleet_yaml(int nodes) {
  std::string y = "seed: 1\ninterfaces:\n";
  const int buses = (nodes + kNodesPerBus - 1) / kNodesPerBus;
  for (int b = 0; b < buses; ++b) y += "  bench" + std::to_string(b) + ": {bit_rate: 250}\n";
  y += "nodes:\n";
  for (int b = 0; b < buses; ++b) {
    const int count = std::min(kNodesPerBus, nodes - b * kNodesPerBus);
    y += "  - {profile: generic-404, interface: bench" + std::to_string(b) +
         ", node_id: 1, count: " + std::to_string(count) + ", name: g" + std::to_string(b) + "}\n";
  }
  return y;
}

// ------------------------------------------------------------------ clients

struct Config {
  int nodes = 1000;
  int seconds = 10;
  int rate = 1000;
  int clients = 4;
  bool pin = false;  // the loop thread alone on the last CPU, the clients on the others
};

// Pins the calling thread to CPU `cpu` (pin: cpu >= 0) or to every CPU but
// `cpu` (pin: cpu < 0, meaning "not ~cpu").
void pin_thread(int cpu) {
  const long n = sysconf(_SC_NPROCESSORS_ONLN);
  if (n < 2) return;
  cpu_set_t set;
  CPU_ZERO(&set);
  for (long c = 0; c < n; ++c)
    if (cpu >= 0 ? c == cpu : c != ~cpu) CPU_SET(int(c), &set);
  pthread_setaffinity_np(pthread_self(), sizeof set, &set);
}

// Monotonic µs bounds of every block: block j is [bounds[j], bounds[j + 1]).
struct Schedule {
  std::vector<TimeUs> bounds;
  int blocks() const { return int(bounds.size()) - 1; }
};

struct CallStats {
  std::vector<std::uint32_t> rtt_us;
  std::uint64_t errors = 0;
  std::uint64_t late_starts = 0;  // calls issued more than 1 ms behind their schedule
  std::string first_error;
  TimeUs slowest = 0;  // the slowest call: round trip, kind, start within its block
  int slowest_kind = 0;
  TimeUs slowest_at = 0;
};

constexpr const char* kCallKinds[] = {"Read 0x1017", "Get Pressure", "Step pressure", "ListFaults"};

sd_bus* connect(const std::string& socket) {
  sd_bus* bus = nullptr;
  const std::string address = "unix:path=" + socket;
  int r = sd_bus_new(&bus);
  if (r >= 0) r = sd_bus_set_address(bus, address.c_str());
  if (r >= 0) r = sd_bus_start(bus);
  if (r < 0) {
    std::fprintf(stderr, "client: cannot connect to %s: %s\n", socket.c_str(), std::strerror(-r));
    std::exit(1);
  }
  return bus;
}

void client(int index, const Config& cfg, const Schedule& sch, const std::string& socket,
            const std::vector<std::string>& paths, CallStats& out) {
  std::mt19937 rng(std::uint32_t(12345 + index));
  std::uniform_int_distribution<std::size_t> any_node(1, paths.size() - 1);  // node 0 is the probe's
  std::uniform_real_distribution<double> pressure(2.0, 8.0);
  const TimeUs period = TimeUs(cfg.clients) * 1'000'000 / cfg.rate;
  for (int b = 1; b < sch.blocks(); b += 2) {
    sleep_until(sch.bounds[std::size_t(b)]);
    sd_bus* bus = connect(socket);
    const TimeUs end = sch.bounds[std::size_t(b) + 1] - kDisconnectUs;
    for (TimeUs at = sch.bounds[std::size_t(b)] + TimeUs(index) * 1'000'000 / cfg.rate; at < end; at += period) {
      sleep_until(at);
      const TimeUs t0 = io::monotonic_now();
      if (t0 - at > 1000) ++out.late_starts;
      const char* path = paths[any_node(rng)].c_str();
      sd_bus_error error = SD_BUS_ERROR_NULL;
      sd_bus_message* reply = nullptr;
      int r = 0;
      const int kind = int(rng() % 4);
      switch (kind) {
        case 0:
          r = sd_bus_call_method(bus, nullptr, path, control::kNodeInterface, "Read", &error, &reply, "qy",
                                 std::uint16_t(0x1017), std::uint8_t(0));
          break;
        case 1:
          r = sd_bus_call_method(bus, nullptr, path, "org.freedesktop.DBus.Properties", "Get", &error, &reply, "ss",
                                 control::kNodeInterface, "Pressure");
          break;
        case 2:
          r = sd_bus_call_method(bus, nullptr, path, control::kNodeInterface, "Step", &error, &reply, "sds", "pressure",
                                 pressure(rng), "bar");
          break;
        default:
          r = sd_bus_call_method(bus, nullptr, path, control::kNodeInterface, "ListFaults", &error, &reply, "");
          break;
      }
      const TimeUs t1 = io::monotonic_now();
      if (r < 0) {
        if (!out.errors++) out.first_error = error.name ? error.name : std::strerror(-r);
      } else {
        out.rtt_us.push_back(std::uint32_t(t1 - t0));
      }
      if (t1 - t0 > out.slowest)
        out.slowest = t1 - t0, out.slowest_kind = kind, out.slowest_at = t0 - sch.bounds[std::size_t(b)];
      sd_bus_error_free(&error);
      sd_bus_message_unref(reply);
    }
    sd_bus_flush_close_unref(bus);
  }
}

struct ProbeStats {
  std::vector<double> latency_ms;  // first matching TPDO1 − Step's return
  std::vector<double> in_pass_ms;  // of which: from the start of the pass that sent it to its flush
  int missing = 0;
  std::string missing_detail;
  std::uint64_t errors = 0;
};

void probe_client(const Schedule& sch, const std::string& socket, const std::string& path, Shared& s, ProbeStats& out) {
  bool high = false;
  // Each step at a random phase of the 10 ms TPDO period: a fixed 200 ms
  // cadence would land at the same point of the PDO schedule every time.
  std::mt19937 rng(4242);
  std::uniform_int_distribution<TimeUs> phase(0, TimeUs(kTpdoMs) * 1000 - 1);
  for (int b = 1; b < sch.blocks(); b += 2) {
    sleep_until(sch.bounds[std::size_t(b)]);
    sd_bus* bus = connect(socket);
    const TimeUs end = sch.bounds[std::size_t(b) + 1] - kDisconnectUs;
    TimeUs returned = 0;
    auto collect = [&] {
      TimeUs pdo = 0, pass = 0, last_time = 0;
      float last = 0, target = 0;
      {
        std::lock_guard lock(s.probe.mutex);
        pdo = s.probe.pdo_time, pass = s.probe.pdo_pass;
        s.probe.armed = false;
        last = s.probe.last_value, last_time = s.probe.last_time, target = s.probe.target;
      }
      if (!returned) return;
      if (pdo) {
        out.latency_ms.push_back(double(pdo - returned) / 1000.0);
        out.in_pass_ms.push_back(double(pdo - pass) / 1000.0);
      } else if (!out.missing++) {
        char text[160];
        std::snprintf(text, sizeof text, "step to %.0f bar returned %.1f ms ago; last TPDO1 %.3f bar, %.1f ms ago",
                      double(target), double(io::monotonic_now() - returned) / 1000.0, double(last),
                      double(io::monotonic_now() - last_time) / 1000.0);
        out.missing_detail = text;
      }
      returned = 0;
    };
    for (TimeUs at = sch.bounds[std::size_t(b)] + 50'000; at + kProbePeriodUs + kTpdoMs * 1000 <= end;
         at += kProbePeriodUs) {
      sleep_until(at + phase(rng));
      collect();
      high = !high;
      const float target = high ? 8.0f : 2.0f;
      {
        std::lock_guard lock(s.probe.mutex);
        s.probe.target = target;
        s.probe.pdo_time = 0;
        s.probe.armed = true;
      }
      sd_bus_error error = SD_BUS_ERROR_NULL;
      sd_bus_message* reply = nullptr;
      int r = sd_bus_call_method(bus, nullptr, path.c_str(), control::kNodeInterface, "Step", &error, &reply, "sds",
                                 "pressure", double(target), "bar");
      returned = io::monotonic_now();
      if (r < 0) {
        ++out.errors;
        returned = 0;
      }
      sd_bus_error_free(&error);
      sd_bus_message_unref(reply);
    }
    sleep_until(end);
    collect();
    sd_bus_flush_close_unref(bus);
  }
}

// ------------------------------------------------------------------ loop

// Daemon::run over the fleet, in fleet time (monotonic − epoch). Returns at `stop`.
void run_loop(test::ControlFleet& fleet, io::EventLoop& loop, control::ControlEndpoints& endpoints, Shared& s,
              TimeUs epoch, const Schedule& sch, const std::atomic<bool>& stop) {
  pthread_setname_np(pthread_self(), "cansim-loop");  // for perf --comm
  io::LoopCore& core = fleet.core();
  TimeUs block_wall = 0, block_cpu = 0, block_user = 0;
  std::uint64_t block_frames = 0;
  while (!stop.load(std::memory_order_relaxed)) {
    const TimeUs mono = io::monotonic_now();
    while (s.block < sch.blocks() && mono >= sch.bounds[std::size_t(s.block + 1)]) {
      const TimeUs cpu = thread_cpu_us(), user = thread_user_us();
      if (s.block >= 0) {
        LoopPhase& p = s.phases[s.phase()];
        p.wall += mono - block_wall, p.cpu += cpu - block_cpu, p.frames += s.frames - block_frames;
        p.user += user - block_user;
        s.blocks[std::size_t(s.block)].wall = mono - block_wall;
        s.blocks[std::size_t(s.block)].cpu = cpu - block_cpu;
      }
      ++s.block;
      block_wall = mono, block_cpu = cpu, block_user = user, block_frames = s.frames;
    }
    const bool measuring = s.block >= 0 && s.block < sch.blocks();
    if (measuring) ++s.phases[s.block % 2].passes;
    const TimeUs cpu0 = measuring ? thread_cpu_us() : 0;
    s.pass_start = mono;
    fleet.run_due(mono - epoch);
    const TimeUs cpu1 = measuring ? thread_cpu_us() : 0;
    // What the nodes sent leaves before the control calls are served, and
    // the calls act here, between two passes (as in Daemon::run).
    if (endpoints.connections()) flush(s, io::monotonic_now(), mono);
    const TimeUs control_at = endpoints.process();
    const TimeUs cpu2 = measuring ? thread_cpu_us() : 0;
    // A node a call made due runs in this pass (as in Daemon::run).
    if (endpoints.connections()) fleet.run_due(io::monotonic_now() - epoch);
    const TimeUs sent = io::monotonic_now();
    flush(s, sent, mono);
    if (measuring) {
      LoopPhase& p = s.phases[s.block % 2];
      p.pass_max = std::max(p.pass_max, sent - mono);
      p.in_run_due += cpu1 - cpu0, p.in_process += cpu2 - cpu1;
    }
    TimeUs next = core.next_deadline();
    next = next == kNever ? kNever : next + epoch;
    next = std::min(next, control_at);
    if (s.block < sch.blocks()) next = std::min(next, sch.bounds[std::size_t(s.block + 1)]);
    next = std::min(next, sent + 100'000);  // sees `stop` within 100 ms
    if (measuring) {
      s.phases[s.block % 2].rearms += next != loop.timer_at();
      s.phases[s.block % 2].control_due += control_at <= sent;
    }
    endpoints.before_sleep(next);
    loop.arm_timer(next);
    bool timer = false;
    int signal = 0;
    loop.wait(-1, timer, signal);
    if (timer && measuring && next > sent) {  // a deadline already passed is no wake-up
      const TimeUs late = io::monotonic_now() - next;
      LoopPhase& p = s.phases[s.block % 2];
      ++p.timer_wakeups;
      p.lateness_sum += double(late);
      p.lateness_max = std::max(p.lateness_max, late);
    }
  }
}

// Thread CPU of one idle wake-up of an io::EventLoop by its timer (nothing
// else done): what every extra loop pass costs on this host at least.
double idle_wakeup_cpu_us() {
  double result = 0;
  std::thread t([&result] {
    io::EventLoop loop;
    if (!loop.open()) return;
    const int n = 200;
    TimeUs at = io::monotonic_now();
    const TimeUs cpu0 = thread_cpu_us();
    for (int i = 0; i < n; ++i) {
      loop.arm_timer(at += 2000);
      bool timer = false;
      int signal = 0;
      while (!timer) loop.wait(-1, timer, signal);
    }
    result = double(thread_cpu_us() - cpu0) / n;
  });
  t.join();
  return result;
}

std::string error_text(TimeUs us) { return (us >= kHistogramUs ? ">= " : "") + std::to_string(us); }

double percentile(std::vector<std::uint32_t>& v, double p) {
  if (v.empty()) return 0;
  std::size_t i = std::min(v.size() - 1, std::size_t(p * double(v.size())));
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(i), v.end());
  return double(v[i]);
}

}  // namespace

int main(int argc, char** argv) {
  Config cfg;
  if (argc > 1) cfg.nodes = std::atoi(argv[1]);
  if (argc > 2) cfg.seconds = std::atoi(argv[2]);
  if (argc > 3) cfg.rate = std::atoi(argv[3]);
  if (argc > 4) cfg.clients = std::atoi(argv[4]);
  if (argc > 5) cfg.pin = std::string(argv[5]) == "pin";
  if (cfg.nodes < 2 || cfg.seconds < 1 || cfg.rate < 1 || cfg.clients < 1) {
    std::fprintf(stderr, "usage: control_bench [NODES>=2] [SECONDS>=1] [RATE>=1] [CLIENTS>=1]\n");
    return 2;
  }

  char dir_template[] = "/tmp/control_bench.XXXXXX";
  if (!mkdtemp(dir_template)) {
    std::perror("mkdtemp");
    return 1;
  }
  const std::string dir = dir_template;
  const std::string socket = dir + "/control";

  Shared s;
  const int buses = (cfg.nodes + kNodesPerBus - 1) / kNodesPerBus;
  s.last_beat.assign(std::size_t(buses) * 128, 0);
  s.beats.resize(std::size_t(buses));
  for (auto& b : s.beats) b.reserve(128);
  s.queued.assign(std::size_t(buses), 0);

  std::printf("building %d generic-404 nodes on %d buses...\n", cfg.nodes, buses);
  std::fflush(stdout);
  test::ControlFleet fleet(fleet_yaml(cfg.nodes), [&s](const std::string& bus) -> std::unique_ptr<io::Transport> {
    return std::make_unique<CountingTransport>(s, std::uint32_t(std::stoul(bus.substr(5))));  // "benchN"
  });
  // Every node: 100 ms heartbeat, TPDO1 every 10 ms, operational.
  const std::uint8_t hb[2] = {kHeartbeatMs, 0}, et[2] = {kTpdoMs, 0};
  for (const control::NodeHandle* h : fleet.nodes()) {
    Node& n = fleet.core().node(h->ref);
    n.write(0x1017, 0, hb, fleet.now());
    n.write(0x1800, 5, et, fleet.now());
    n.nmt_local(0x01, fleet.now());
    fleet.core().refresh(h->ref);
  }
  const control::NodeHandle& node0 = fleet.node("bench0/g0/0");
  s.probe_cob = 0x180u + fleet.core().node(node0.ref).node_id();
  std::vector<std::string> paths{control::node_path(node0)};
  for (const control::NodeHandle* h : fleet.nodes())
    if (h != &node0) paths.push_back(control::node_path(*h));

  io::EventLoop loop;
  if (!loop.open()) {
    std::fprintf(stderr, "event loop: %s\n", loop.error().c_str());
    std::exit(1);
  }
  control::ControlEndpoints endpoints(loop, fleet.service());
  endpoints.listen(socket);

  const double wakeup_before = idle_wakeup_cpu_us();
  const TimeUs epoch = io::monotonic_now() - fleet.now();
  const int per_phase = std::max(1, int((TimeUs(cfg.seconds) * 1'000'000 + kBlockUs / 2) / kBlockUs));
  const TimeUs block_us = TimeUs(cfg.seconds) * 1'000'000 / per_phase;
  Schedule sch;
  for (int j = 0; j <= 2 * per_phase; ++j)
    sch.bounds.push_back(epoch + fleet.now() + kWarmUpUs + kBoundaryOffsetUs + j * block_us);
  s.blocks.resize(std::size_t(sch.blocks()));
  std::printf(
      "warm-up 2 s, then %d s without clients (A) and %d s with %d clients at %d calls/s + the set->PDO "
      "probe (B), alternating in %d blocks of %.1f s each\n",
      cfg.seconds, cfg.seconds, cfg.clients, cfg.rate, per_phase, double(block_us) / 1e6);
  std::fflush(stdout);

  std::atomic<bool> stop{false};
  const int loop_cpu = int(sysconf(_SC_NPROCESSORS_ONLN)) - 1;
  std::thread loop_thread([&] {
    if (cfg.pin) pin_thread(loop_cpu);
    run_loop(fleet, loop, endpoints, s, epoch, sch, stop);
  });
  std::vector<CallStats> calls(std::size_t(cfg.clients));
  std::vector<std::thread> threads;
  for (int i = 0; i < cfg.clients; ++i)
    threads.emplace_back([&, i] {
      if (cfg.pin) pin_thread(~loop_cpu);
      client(i, cfg, sch, socket, paths, calls[std::size_t(i)]);
    });
  ProbeStats probe;
  threads.emplace_back([&] {
    if (cfg.pin) pin_thread(~loop_cpu);
    probe_client(sch, socket, paths[0], s, probe);
  });
  for (std::thread& t : threads) t.join();
  sleep_until(sch.bounds.back() + 200'000);
  stop = true;
  loop_thread.join();
  std::filesystem::remove_all(dir);
  const double wakeup_after = idle_wakeup_cpu_us();

  // ---------------------------------------------------------------- figures
  std::vector<std::uint32_t> rtt;
  std::uint64_t errors = 0, late = 0;
  std::string first_error;
  const CallStats* slowest = &calls[0];
  for (CallStats& c : calls) {
    rtt.insert(rtt.end(), c.rtt_us.begin(), c.rtt_us.end());
    errors += c.errors, late += c.late_starts;
    if (first_error.empty()) first_error = c.first_error;
    if (c.slowest > slowest->slowest) slowest = &c;
  }
  double cpu_pct[2], user_pct[2], hb_mean[2];
  for (int p = 0; p < 2; ++p) {
    const LoopPhase& ph = s.phases[p];
    const double wall = double(ph.wall) / 1e6;
    cpu_pct[p] = 100.0 * double(ph.cpu) / double(ph.wall);
    user_pct[p] = 100.0 * double(ph.user) / double(ph.wall);
    hb_mean[p] = ph.hb.mean();
    std::printf("\n%c: %s (%.1f s)\n", p ? 'B' : 'A', p ? "with clients" : "no clients", wall);
    std::printf("  loop thread CPU       %.2f %% of wall time (%.0f ms CPU, %.2f us per frame); per block:", cpu_pct[p],
                double(ph.cpu) / 1000.0, double(ph.cpu) / double(ph.frames));
    for (std::size_t j = std::size_t(p); j < s.blocks.size(); j += 2)
      std::printf(" %.1f", 100.0 * double(s.blocks[j].cpu) / double(s.blocks[j].wall));
    std::printf("\n  loop CPU in user space %.2f %% of wall time (the kernel's: %.2f %%)",
                100.0 * double(ph.user) / (wall * 1e6), 100.0 * double(ph.cpu - ph.user) / (wall * 1e6));
    std::printf(
        "\n  loop CPU split        run_due %.1f ms/s, control process() %.1f ms/s, the rest (wake-ups, "
        "epoll, timer) %.1f ms/s\n",
        double(ph.in_run_due) / wall / 1000.0, double(ph.in_process) / wall / 1000.0,
        double(ph.cpu - ph.in_run_due - ph.in_process) / wall / 1000.0);
    std::printf("  frames/s              %.0f\n", double(ph.frames) / wall);
    std::printf(
        "  loop passes           %.0f/s (%.0f/s woken by the timer, timer re-armed %.0f/s, control asked for an "
        "immediate pass %.0f/s), longest %.2f ms; timer wake-up lateness mean %.0f us, max %.2f ms\n",
        double(ph.passes) / wall, double(ph.timer_wakeups) / wall, double(ph.rearms) / wall,
        double(ph.control_due) / wall, double(ph.pass_max) / 1000.0,
        ph.timer_wakeups ? ph.lateness_sum / double(ph.timer_wakeups) : 0.0, double(ph.lateness_max) / 1000.0);
    std::printf(
        "  heartbeats            %llu (%.0f/s), |period - 100 ms| mean %.0f us, p50 %s us, p99 %s us, "
        "max %.2f ms; mean per block:",
        (unsigned long long)ph.hb.beats, double(ph.hb.beats) / wall, ph.hb.mean(),
        error_text(ph.hb.percentile(0.50)).c_str(), error_text(ph.hb.percentile(0.99)).c_str(),
        double(ph.hb.max) / 1000.0);
    for (std::size_t j = std::size_t(p); j < s.blocks.size(); j += 2)
      std::printf(" %.0f", s.blocks[j].beats ? s.blocks[j].error_sum / double(s.blocks[j].beats) : 0.0);
    std::printf("\n");
    if (p == 1) {
      std::printf("  control calls         %zu done (%.0f/s), %llu errors%s%s, %llu started > 1 ms late\n", rtt.size(),
                  double(rtt.size()) / wall, (unsigned long long)errors,
                  first_error.empty() ? "" : ", first: ", first_error.c_str(), (unsigned long long)late);
      const double p50 = percentile(rtt, 0.50), p99 = percentile(rtt, 0.99);
      std::printf("  call round trip       p50 %.0f us, p99 %.0f us, max %.2f ms (%s, %.3f s into its block)\n", p50,
                  p99, double(slowest->slowest) / 1000.0, kCallKinds[slowest->slowest_kind],
                  double(slowest->slowest_at) / 1e6);
      const double per_call =
          rtt.empty() ? 0
                      : (double(ph.cpu) - double(s.phases[0].cpu) * double(ph.wall) / double(s.phases[0].wall)) /
                            double(rtt.size() + probe.latency_ms.size());
      const double calls_done = double(rtt.size() + probe.latency_ms.size());
      const double extra_passes =
          double(ph.passes) - double(s.phases[0].passes) * double(ph.wall) / double(s.phases[0].wall);
      std::printf(
          "  loop CPU per call     %.1f us (B's CPU minus A's for the same wall time, over the calls): "
          "%.1f us in process(), %.2f extra loop passes per call\n",
          per_call, double(ph.in_process) / calls_done, extra_passes / calls_done);
    } else {
      std::printf("  control calls         none (no connection)\n");
    }
  }
  double lmin = 0, lmax = 0, lsum = 0;
  if (!probe.latency_ms.empty()) {
    lmin = *std::min_element(probe.latency_ms.begin(), probe.latency_ms.end());
    lmax = *std::max_element(probe.latency_ms.begin(), probe.latency_ms.end());
    for (double v : probe.latency_ms) lsum += v;
  }
  const double lmean = probe.latency_ms.empty() ? 0 : lsum / double(probe.latency_ms.size());
  const double bound_ms = kTpdoMs + 1.0;
  std::size_t over = 0;
  for (double v : probe.latency_ms) over += v > bound_ms;
  std::printf(
      "\nset->PDO (Step node 0 to 2 / 8 bar every 200 ms in B; first TPDO1 within 0.1 bar, minus the "
      "call's return)\n");
  std::printf("  %zu steps, %llu errors: min %.2f ms, mean %.2f ms, max %.2f ms; %zu over the %.0f ms bound\n",
              probe.latency_ms.size(), (unsigned long long)probe.errors, lmin, lmean, lmax, over, bound_ms);
  if (!probe.in_pass_ms.empty()) {
    double sum = 0;
    for (double v : probe.in_pass_ms) sum += v;
    std::printf(
        "  of which the PDO waited in its loop pass (pass start to flush, the pass's other frames and the "
        "calls processed after it): mean %.2f ms, max %.2f ms\n",
        sum / double(probe.in_pass_ms.size()), *std::max_element(probe.in_pass_ms.begin(), probe.in_pass_ms.end()));
  }
  if (probe.missing)
    std::printf("  %d steps without such a PDO before the next step, first: %s\n", probe.missing,
                probe.missing_detail.c_str());
  const TimeUs held =
      std::max({s.phases[0].lateness_max, s.phases[0].pass_max, s.phases[1].lateness_max, s.phases[1].pass_max});
  if (held > 50'000)
    std::printf(
        "\nWARNING: the host held the loop thread up to %.0f ms (timer lateness or one pass): this run's "
        "figures measure the host more than cansimd\n",
        double(held) / 1000.0);
  std::printf(
      "\nthis host: one idle timer wake-up of an EventLoop costs %.1f us (before) / %.1f us (after) of "
      "thread CPU\n",
      wakeup_before, wakeup_after);
  const double cpu_delta = cpu_pct[0] > 0 ? 100.0 * (cpu_pct[1] - cpu_pct[0]) / cpu_pct[0] : 0;
  std::printf(
      "\ncontrol calls: %+.1f %% loop CPU (%.2f -> %.2f %% of a core, %+.2f points), heartbeat error %.0f us "
      "-> %.0f us, set->PDO max %.2f ms%s\n",
      cpu_delta, cpu_pct[0], cpu_pct[1], cpu_pct[1] - cpu_pct[0], hb_mean[0], hb_mean[1], lmax,
      probe.missing ? " (some steps had no PDO: see above)" : "");
  std::printf("               in user space: %+.1f %% (%.2f -> %.2f %% of a core, %+.2f points)\n",
              user_pct[0] > 0 ? 100.0 * (user_pct[1] - user_pct[0]) / user_pct[0] : 0.0, user_pct[0], user_pct[1],
              user_pct[1] - user_pct[0]);
  return 0;
}
