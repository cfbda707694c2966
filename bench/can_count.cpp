// can_count — a cheap CAN_RAW receiver for in-VM throughput and heartbeat
// benchmarks (scripts/bench-vm). It shares one vCPU with the sender, so it
// does as little as possible per frame: recvmmsg batches, a kernel timestamp
// per frame (SO_TIMESTAMPNS), a few counters per COB-ID.
//
// usage: can_count [options] IFACE...
//   --seconds N       length of the measurement window (default 10)
//   --skip S          the window starts S seconds after the first frame (default 1)
//   --max-wait S      give up if no frame arrives within S seconds (default 120)
//   --period-ms P     heartbeat analysis: frames 0x701..0x77F with 1 data byte
//                     other than 0 (boot-up) are heartbeats of period P ms
//   --expect-nodes K  heartbeat producers expected (default: those seen)
//   --pid PID         report that process's CPU use during the window
//   --rcvbuf BYTES    socket receive buffer (default 32 MiB; SO_RCVBUFFORCE as root)
//   --poll-ms MS      after reading, sleep MS ms so frames arrive in large
//                     batches (default 2; 0 = wake up for every frame). The
//                     kernel timestamps each frame on arrival, so the sleep
//                     does not change the measured periods; the buffer holds
//                     tens of thousands of frames, far more than MS ms bring.
//
// Prints "key=value" lines (one per figure) for scripts, e.g.
//   frames=400000 seconds=10.000 fps=40000 drops=0 ...
// Drops are the kernel's per-socket overflow counter (SO_RXQ_OVFL): frames
// the kernel had for us but could not queue because our buffer was full.
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/epoll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

constexpr int kBatch = 64;
constexpr int kIds = 2048;  // 11-bit identifiers; 29-bit frames are only counted

std::int64_t mono_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

struct IdStats {
  std::uint64_t count = 0;
  std::int64_t first = 0, last = 0;  // kernel receive time, ns
  std::int64_t max_gap = 0;
  double sum_abs_dev = 0;  // sum of |gap - period| (heartbeats only)
};

struct Socket {
  std::string name;
  int fd = -1;
  std::uint32_t ovfl = 0;           // latest SO_RXQ_OVFL value
  std::uint32_t ovfl_at_start = 0;  // value when the window opened
  std::uint64_t frames = 0;         // in the window
  std::uint64_t before = 0;         // before the window
  std::vector<IdStats> ids;
};

[[noreturn]] void die(const char* what) {
  std::fprintf(stderr, "can_count: %s: %s\n", what, std::strerror(errno));
  std::exit(2);
}

void usage() {
  std::fprintf(stderr,
               "usage: can_count [--seconds N] [--skip S] [--max-wait S] [--period-ms P]\n"
               "                 [--expect-nodes K] [--pid PID] [--rcvbuf BYTES] [--poll-ms MS] IFACE...\n");
  std::exit(2);
}

// utime and stime of a process in clock ticks; false if unreadable.
bool proc_cpu_ticks(int pid, long long& user, long long& sys) {
  char path[64];
  std::snprintf(path, sizeof path, "/proc/%d/stat", pid);
  FILE* f = std::fopen(path, "r");
  if (!f) return false;
  char buf[1024];
  std::size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  buf[n] = 0;
  const char* p = std::strrchr(buf, ')');  // the command name may hold spaces
  if (!p) return false;
  // After ") ": field 3 (state) ... utime is field 14, stime field 15.
  unsigned long long ut = 0, st = 0;
  if (std::sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu", &ut, &st) != 2) return false;
  user = (long long)ut;
  sys = (long long)st;
  return true;
}

// Whole-machine CPU from /proc/stat: total and idle jiffies, softirq jiffies.
struct MachineCpu {
  unsigned long long total = 0, idle = 0, softirq = 0;
};
MachineCpu machine_cpu() {
  MachineCpu m;
  FILE* f = std::fopen("/proc/stat", "r");
  if (!f) return m;
  unsigned long long v[10] = {};
  int n = std::fscanf(f, "cpu %llu %llu %llu %llu %llu %llu %llu %llu %llu %llu", &v[0], &v[1], &v[2], &v[3], &v[4],
                      &v[5], &v[6], &v[7], &v[8], &v[9]);
  std::fclose(f);
  for (int i = 0; i < n && i < 8; ++i) m.total += v[i];  // guest time is already in user
  m.idle = v[3] + v[4];
  m.softirq = v[6];
  return m;
}

double self_cpu_s() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return double(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) / 1e6;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 10, skip = 1, max_wait = 120;
  double period_ms = 0;
  long expect_nodes = -1;
  int pid = 0;
  int rcvbuf = 32 << 20;
  double poll_ms = 2;
  std::vector<Socket> socks;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto val = [&]() -> const char* {
      if (i + 1 >= argc) usage();
      return argv[++i];
    };
    if (a == "--seconds") seconds = std::atof(val());
    else if (a == "--skip") skip = std::atof(val());
    else if (a == "--max-wait") max_wait = std::atof(val());
    else if (a == "--period-ms") period_ms = std::atof(val());
    else if (a == "--expect-nodes") expect_nodes = std::atol(val());
    else if (a == "--pid") pid = std::atoi(val());
    else if (a == "--rcvbuf") rcvbuf = std::atoi(val());
    else if (a == "--poll-ms") poll_ms = std::atof(val());
    else if (a == "-h" || a == "--help") usage();
    else if (!a.empty() && a[0] == '-') usage();
    else {
      socks.emplace_back();
      socks.back().name = a;
    }
  }
  if (socks.empty() || seconds <= 0) usage();

  int ep = epoll_create1(EPOLL_CLOEXEC);
  if (ep < 0) die("epoll_create1");
  for (std::size_t k = 0; k < socks.size(); ++k) {
    Socket& s = socks[k];
    s.ids.resize(kIds);
    s.fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
    if (s.fd < 0) die("socket(PF_CAN)");
    if (setsockopt(s.fd, SOL_SOCKET, SO_RCVBUFFORCE, &rcvbuf, sizeof rcvbuf) < 0)
      setsockopt(s.fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    int one = 1;
    if (setsockopt(s.fd, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one) < 0) die("SO_RXQ_OVFL");
    if (setsockopt(s.fd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one) < 0) die("SO_TIMESTAMPNS");
    unsigned idx = if_nametoindex(s.name.c_str());
    if (!idx) {
      std::fprintf(stderr, "can_count: no interface %s\n", s.name.c_str());
      return 2;
    }
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = int(idx);
    if (bind(s.fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) die("bind");
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u32 = std::uint32_t(k);
    if (epoll_ctl(ep, EPOLL_CTL_ADD, s.fd, &ev) < 0) die("epoll_ctl");
  }
  std::printf("ready=1\n");
  std::fflush(stdout);

  const std::int64_t period_ns = std::int64_t(period_ms * 1e6);
  can_frame frames[kBatch];
  iovec iov[kBatch];
  mmsghdr msgs[kBatch];
  alignas(cmsghdr) char ctrl[kBatch][CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t)) + 64];

  const std::int64_t started = mono_ns();
  std::int64_t window_start = 0, window_end = 0;  // monotonic ns; 0 = no frame yet
  bool in_window = false;
  long long user_start = 0, sys_start = 0, user_end = 0, sys_end = 0;
  bool cpu_ok = false;
  double self_start = 0, self_end = 0;
  MachineCpu machine_start, machine_end;
  std::uint64_t eff_frames = 0;

  auto open_window = [&]() {
    in_window = true;
    for (auto& s : socks) s.ovfl_at_start = s.ovfl;
    if (pid) cpu_ok = proc_cpu_ticks(pid, user_start, sys_start);
    self_start = self_cpu_s();
    machine_start = machine_cpu();
  };

  for (;;) {
    std::int64_t now = mono_ns();
    if (!window_start && now - started > std::int64_t(max_wait * 1e9)) {
      std::fprintf(stderr, "can_count: no frame within %.0f s\n", max_wait);
      std::printf("frames=0\nerror=no-frames\n");
      return 1;
    }
    if (!in_window && pid && kill(pid, 0) < 0 && errno == ESRCH) {
      std::fprintf(stderr, "can_count: process %d ended before the window\n", pid);
      std::printf("frames=0\nerror=process-ended\n");
      return 1;
    }
    if (window_start && !in_window && now >= window_start) open_window();
    if (in_window && now >= window_end) break;
    int timeout_ms = 100;
    if (window_start) {
      std::int64_t next = in_window ? window_end : window_start;
      timeout_ms = int(std::max<std::int64_t>(0, (next - now) / 1'000'000) + 1);
      if (timeout_ms > 100) timeout_ms = 100;
    }
    epoll_event evs[16];
    int ne = epoll_wait(ep, evs, 16, timeout_ms);
    if (ne < 0) {
      if (errno == EINTR) continue;
      die("epoll_wait");
    }
    for (int e = 0; e < ne; ++e) {
      Socket& s = socks[evs[e].data.u32];
      for (;;) {
        for (int i = 0; i < kBatch; ++i) {
          iov[i] = {&frames[i], sizeof(can_frame)};
          msgs[i].msg_hdr = msghdr{};
          msgs[i].msg_hdr.msg_iov = &iov[i];
          msgs[i].msg_hdr.msg_iovlen = 1;
          msgs[i].msg_hdr.msg_control = ctrl[i];
          msgs[i].msg_hdr.msg_controllen = sizeof ctrl[i];
        }
        int n = recvmmsg(s.fd, msgs, kBatch, MSG_DONTWAIT, nullptr);
        if (n < 0) {
          if (errno == EAGAIN || errno == EINTR) break;
          die("recvmmsg");
        }
        std::int64_t batch_now = mono_ns();
        if (!window_start) {
          window_start = batch_now + std::int64_t(skip * 1e9);
          window_end = window_start + std::int64_t(seconds * 1e9);
        }
        if (!in_window && batch_now >= window_start) open_window();
        bool counting = in_window && batch_now < window_end;
        for (int i = 0; i < n; ++i) {
          std::int64_t ts = 0;
          for (cmsghdr* c = CMSG_FIRSTHDR(&msgs[i].msg_hdr); c; c = CMSG_NXTHDR(&msgs[i].msg_hdr, c)) {
            if (c->cmsg_level != SOL_SOCKET) continue;
            if (c->cmsg_type == SO_TIMESTAMPNS) {
              timespec t;
              std::memcpy(&t, CMSG_DATA(c), sizeof t);
              ts = std::int64_t(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
            } else if (c->cmsg_type == SO_RXQ_OVFL) {
              std::memcpy(&s.ovfl, CMSG_DATA(c), sizeof s.ovfl);
            }
          }
          if (!counting) {
            ++s.before;
            continue;
          }
          ++s.frames;
          const can_frame& f = frames[i];
          if (f.can_id & (CAN_EFF_FLAG | CAN_ERR_FLAG)) {
            ++eff_frames;
            continue;
          }
          std::uint32_t id = f.can_id & CAN_SFF_MASK;
          IdStats& st = s.ids[id];
          bool beat =
              period_ns && id > 0x700 && id < 0x780 && !(f.can_id & CAN_RTR_FLAG) && f.len == 1 && f.data[0] != 0;
          if (st.count) {
            std::int64_t gap = ts - st.last;
            if (gap > st.max_gap) st.max_gap = gap;
            if (beat) st.sum_abs_dev += std::fabs(double(gap - period_ns));
          } else {
            st.first = ts;
          }
          st.last = ts;
          ++st.count;
        }
        if (n < kBatch) break;
      }
    }
    if (ne > 0 && poll_ms > 0) {
      timespec nap{0, long(poll_ms * 1e6)};
      nanosleep(&nap, nullptr);
    }
  }
  if (pid && cpu_ok) cpu_ok = proc_cpu_ticks(pid, user_end, sys_end);
  self_end = self_cpu_s();
  machine_end = machine_cpu();
  const double window_s = double(window_end - window_start) / 1e9;

  std::uint64_t total = 0, drops = 0, before = 0, ids_seen = 0;
  for (const auto& s : socks) {
    total += s.frames;
    before += s.before;
    drops += s.ovfl - s.ovfl_at_start;
    for (const auto& st : s.ids) ids_seen += st.count > 0;
  }
  std::printf(
      "interfaces=%zu\nseconds=%.3f\nframes=%llu\nfps=%.0f\ndrops=%llu\ndrops_total=%llu\n"
      "frames_before_window=%llu\ncob_ids=%llu\neff_frames=%llu\n",
      socks.size(), window_s, (unsigned long long)total, double(total) / window_s, (unsigned long long)drops,
      [&] {
        unsigned long long d = 0;
        for (const auto& s : socks) d += s.ovfl;
        return d;
      }(),
      (unsigned long long)before, (unsigned long long)ids_seen, (unsigned long long)eff_frames);
  for (const auto& s : socks)
    std::printf("iface_%s_frames=%llu\niface_%s_drops=%u\n", s.name.c_str(), (unsigned long long)s.frames,
                s.name.c_str(), s.ovfl - s.ovfl_at_start);

  if (period_ns) {
    std::uint64_t nodes = 0, timed = 0, beats = 0, missed = 0, expected_span = 0;
    double sum_period = 0, sum_err = 0, max_err = 0, sum_jitter = 0;
    std::int64_t max_gap = 0;
    for (const auto& s : socks)
      for (int id = 0x701; id < 0x780; ++id) {
        const IdStats& st = s.ids[id];
        if (st.count == 0) continue;
        ++nodes;
        beats += st.count;
        if (st.max_gap > max_gap) max_gap = st.max_gap;
        if (st.count < 2) continue;
        ++timed;
        // Beats the node should have sent between its first and last one here.
        std::uint64_t span = std::uint64_t(std::llround(double(st.last - st.first) / double(period_ns))) + 1;
        expected_span += span;
        if (span > st.count) missed += span - st.count;
        double mean = double(st.last - st.first) / double(st.count - 1);
        double err = std::fabs(mean - double(period_ns)) / double(period_ns) * 100;
        sum_period += mean;
        sum_err += err;
        if (err > max_err) max_err = err;
        sum_jitter += st.sum_abs_dev / double(st.count - 1);
      }
    long k = expect_nodes >= 0 ? expect_nodes : long(nodes);
    double expected = double(k) * window_s * 1000.0 / period_ms;
    std::printf(
        "hb_period_ms=%.3f\nhb_nodes_seen=%llu\nhb_nodes_expected=%ld\nhb_expected=%.0f\nhb_received=%llu\n"
        "hb_received_pct=%.2f\nhb_missed=%llu\nhb_expected_between_first_last=%llu\n",
        period_ms, (unsigned long long)nodes, k, expected, (unsigned long long)beats,
        expected > 0 ? double(beats) / expected * 100 : 0.0, (unsigned long long)missed,
        (unsigned long long)expected_span);
    if (timed) {
      std::printf(
          "hb_mean_period_ms=%.4f\nhb_mean_period_error_pct=%.3f\nhb_max_period_error_pct=%.3f\n"
          "hb_mean_abs_jitter_ms=%.3f\nhb_max_gap_ms=%.3f\n",
          sum_period / double(timed) / 1e6, sum_err / double(timed), max_err, sum_jitter / double(timed) / 1e6,
          double(max_gap) / 1e6);
    }
  }
  if (pid) {
    double hz = double(sysconf(_SC_CLK_TCK));
    if (cpu_ok) {
      double u = double(user_end - user_start) / hz, k = double(sys_end - sys_start) / hz;
      std::printf("pid_cpu_s=%.2f\npid_cpu_pct=%.1f\npid_user_pct=%.1f\npid_sys_pct=%.1f\n", u + k,
                  (u + k) / window_s * 100, u / window_s * 100, k / window_s * 100);
    } else {
      std::printf("pid_cpu_s=nan\npid_cpu_pct=nan\n");
    }
  }
  if (double dt = double(machine_end.total - machine_start.total); dt > 0)
    std::printf("machine_idle_pct=%.1f\nmachine_softirq_pct=%.1f\n",
                double(machine_end.idle - machine_start.idle) / dt * 100,
                double(machine_end.softirq - machine_start.softirq) / dt * 100);
  std::printf("self_cpu_s=%.2f\nself_cpu_pct=%.1f\n", self_end - self_start, (self_end - self_start) / window_s * 100);
  return 0;
}
