// Frames per second and latency through cansimd's socketcand bus
// (docs/socketcand.md), with small C++ clients (one thread, poll, the
// protocol's client side of io/socketcand.hpp) on 127.0.0.1 against a real
// cansimd started here:
//
//   ping-pong  N clients, each an SDO expedited upload of 0x1000 from its own
//              generic-404 node, the next request when the answer arrived:
//              round trips per second, frames per second on the bus (request
//              + answer), frames per second written to the clients (each
//              client receives every frame but its own), round-trip time
//              p50 / p99 (send() to the answer parsed). On an ideal bus (the
//              transport alone) and on a timed 1 Mbit/s bus (+ 2 frame times,
//              ~0.24 ms, and the wake-up at each frame's end).
//   fan-out    one sender streams 8-byte frames at 5,000 frames/s (one per
//              send()) to N receivers, on the ideal and the timed bus:
//              frames per second each receiver gets, one-way latency p50 /
//              p99 (the sender's send() of a frame to a receiver parsing it).
//
// Also cansimd's CPU time per second of each run (/proc/PID/stat).
//
//   ./build/bench/socketcand_bench ./build/cansimd [SECONDS=5]
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "io/socketcand.hpp"

using namespace cansim;
namespace sc = cansim::io::socketcand;

namespace {

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

[[noreturn]] void die(const std::string& what) {
  std::fprintf(stderr, "socketcand_bench: %s\n", what.c_str());
  std::exit(1);
}

class Client {
 public:
  Client(const std::string& bus, std::uint16_t port) {
    fd_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) < 0) die("connect: " + std::string(strerror(errno)));
    const int on = 1;
    setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    expect("hi");
    send("< open " + bus + " >");
    expect("ok");
    send("< rawmode >");
    expect("ok");
    send("< echo >");
    expect("echo");
  }
  ~Client() { close(fd_); }
  int fd() const { return fd_; }
  void send(const std::string& s) {
    std::size_t off = 0;
    while (off < s.size()) {
      const ssize_t n = ::send(fd_, s.data() + off, s.size() - off, MSG_NOSIGNAL);
      if (n <= 0) die("send: " + std::string(strerror(errno)));
      off += std::size_t(n);
    }
  }
  // Reads what waits (blocking once); hands each frame to fn.
  template <typename Fn>
  void read(Fn&& fn) {
    char buf[65536];
    const ssize_t n = recv(fd_, buf, sizeof buf, 0);
    if (n <= 0) die("recv: the server closed the connection");
    reader_.append(std::string_view(buf, std::size_t(n)));
    std::string body;
    while (reader_.next(body)) {
      CanFrame f;
      double t = 0;
      if (sc::parse_frame_message(body, f, t)) fn(f);
    }
  }

 private:
  // The next message but the bus's frames (they may come before `< echo >`).
  void expect(const char* word) {
    std::string body;
    for (;;) {
      while (!reader_.next(body)) {
        char buf[4096];
        const ssize_t n = recv(fd_, buf, sizeof buf, 0);
        if (n <= 0) die("handshake: the server closed the connection");
        reader_.append(std::string_view(buf, std::size_t(n)));
      }
      if (body.find(" frame ") != 0) break;
    }
    if (body.find(word) == std::string::npos) die("handshake: expected " + std::string(word) + ", got " + body);
  }
  int fd_ = -1;
  sc::MessageReader reader_;
};

struct Percentiles {
  double p50_us = 0, p99_us = 0;
};
Percentiles percentiles(std::vector<std::int64_t>& ns) {
  if (ns.empty()) return {};
  std::sort(ns.begin(), ns.end());
  return {ns[ns.size() / 2] / 1e3, ns[std::min(ns.size() - 1, ns.size() * 99 / 100)] / 1e3};
}

double cpu_seconds(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string s((std::istreambuf_iterator<char>(f)), {});
  std::istringstream in(s.substr(s.rfind(')') + 2));
  std::string field;
  unsigned long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && in >> field; ++i) {
    if (i == 14) utime = std::stoul(field);
    if (i == 15) stime = std::stoul(field);
  }
  return double(utime + stime) / double(sysconf(_SC_CLK_TCK));
}

std::string sdo_request(int node) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "< send %X 8 40 0 10 0 0 0 0 0 >", 0x600 + node);
  return buf;
}

struct Result {
  double rate = 0, bus_fps = 0, client_fps = 0, cpu = 0;
  Percentiles lat;
};

Result ping_pong(const std::string& bus, std::uint16_t port, int clients, double seconds, pid_t daemon) {
  std::vector<std::unique_ptr<Client>> c;
  for (int i = 0; i < clients; ++i) c.push_back(std::make_unique<Client>(bus, port));
  std::vector<std::int64_t> sent_at(std::size_t(clients), 0), rtt;
  rtt.reserve(1 << 20);
  std::uint64_t trips = 0, delivered = 0;
  std::vector<pollfd> fds;
  for (auto& cl : c) fds.push_back({cl->fd(), POLLIN, 0});
  const double cpu0 = cpu_seconds(daemon);
  const std::int64_t t0 = now_ns(), end = t0 + std::int64_t(seconds * 1e9);
  for (int i = 0; i < clients; ++i) sent_at[std::size_t(i)] = now_ns(), c[std::size_t(i)]->send(sdo_request(i + 1));
  while (now_ns() < end) {
    if (poll(fds.data(), fds.size(), 100) <= 0) continue;
    for (int i = 0; i < clients; ++i) {
      if (!(fds[std::size_t(i)].revents & POLLIN)) continue;
      c[std::size_t(i)]->read([&](const CanFrame& f) {
        ++delivered;
        if (f.id != std::uint32_t(0x580 + i + 1)) return;
        const std::int64_t t = now_ns();
        rtt.push_back(t - sent_at[std::size_t(i)]);
        ++trips;
        sent_at[std::size_t(i)] = t;
        c[std::size_t(i)]->send(sdo_request(i + 1));
      });
    }
  }
  const double dt = double(now_ns() - t0) / 1e9;
  Result r;
  r.cpu = (cpu_seconds(daemon) - cpu0) / dt;
  r.rate = double(trips) / dt;
  r.bus_fps = 2 * r.rate;
  r.client_fps = double(delivered) / dt;
  r.lat = percentiles(rtt);
  return r;
}

// rate: frames per second the sender offers (0: as fast as the server takes them).
Result fan_out(const std::string& bus, std::uint16_t port, int receivers, double seconds, pid_t daemon, double rate) {
  Client sender(bus, port);
  std::vector<std::unique_ptr<Client>> rx;
  for (int i = 0; i < receivers; ++i) rx.push_back(std::make_unique<Client>(bus, port));
  constexpr std::size_t kRing = 1 << 20;
  std::vector<std::int64_t> sent_at(kRing, 0), latency;
  latency.reserve(1 << 22);
  std::uint64_t got = 0;
  bool done = false;
  std::int64_t end = 0;
  const double cpu0 = cpu_seconds(daemon);
  const std::int64_t t0 = now_ns();
  end = t0 + std::int64_t(seconds * 1e9);
  std::thread reader([&] {
    std::vector<pollfd> fds;
    for (auto& c : rx) fds.push_back({c->fd(), POLLIN, 0});
    while (!done) {
      if (poll(fds.data(), fds.size(), 100) <= 0) continue;
      for (std::size_t i = 0; i < rx.size(); ++i)
        if (fds[i].revents & POLLIN)
          rx[i]->read([&](const CanFrame& f) {
            std::uint32_t seq = 0;
            std::memcpy(&seq, f.data, 4);
            ++got;
            const std::int64_t at = sent_at[seq % kRing];
            if (at) latency.push_back(now_ns() - at);
          });
    }
  });
  std::uint32_t seq = 0;
  char text[80];
  const int kPerSend = rate > 0 ? 1 : 16;
  const std::int64_t period = rate > 0 ? std::int64_t(kPerSend * 1e9 / rate) : 0;
  std::int64_t next = t0;
  while (now_ns() < end) {
    if (period) {
      next += period;
      std::this_thread::sleep_for(std::chrono::nanoseconds(next - now_ns()));
    }
    // Each frame carries its sequence number.
    std::string batch;
    for (int k = 0; k < kPerSend; ++k, ++seq) {
      std::snprintf(text, sizeof text, "< send 7F0 8 %x %x %x %x 0 0 0 0 >", seq & 0xFF, (seq >> 8) & 0xFF,
                    (seq >> 16) & 0xFF, seq >> 24);
      batch += text;
    }
    const std::int64_t t = now_ns();
    for (std::uint32_t k = seq - kPerSend; k != seq; ++k) sent_at[k % kRing] = t;
    sender.send(batch);
  }
  const double dt = double(now_ns() - t0) / 1e9;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  done = true;
  reader.join();
  Result r;
  r.cpu = (cpu_seconds(daemon) - cpu0) / dt;
  r.bus_fps = double(seq) / dt;
  r.client_fps = double(got) / dt / receivers;
  r.lat = percentiles(latency);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) die("usage: socketcand_bench CANSIMD [SECONDS=5]");
  const double seconds = argc > 2 ? std::atof(argv[2]) : 5.0;
  signal(SIGPIPE, SIG_IGN);
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("socketcand-bench-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  std::filesystem::create_symlink(std::string(CANSIM_SOURCE_DIR) + "/profiles", dir / "profiles");
  {
    std::ofstream f(dir / "fleet.yaml");
    f << "interfaces:\n"
         "  ideal: {transport: socketcand, listen: \"127.0.0.1:0\", bus_model: ideal}\n"
         "  timed: {transport: socketcand, listen: \"127.0.0.1:0\", bit_rate: 1000}\n"
         "nodes:\n"
         "  - {profile: generic-404, interface: ideal, node_id: 1, count: 8, name: a}\n"
         "  - {profile: generic-404, interface: timed, node_id: 1, count: 8, name: b, bit_rate: 1000}\n";
  }
  const std::string addresses = (dir / "addresses").string();
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string config = (dir / "fleet.yaml").string(), state = (dir / "state").string(),
                      control = (dir / "control").string();
    execl(argv[1], argv[1], "--config", config.c_str(), "--state-dir", state.c_str(), "--control-socket",
          control.c_str(), "--bus", "none", "--log-level", "warn", "--address-file", addresses.c_str(), nullptr);
    _exit(127);
  }
  std::map<std::string, std::uint16_t> port;
  for (int i = 0; i < 200 && port.size() < 2; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::ifstream f(addresses);
    std::string name, host;
    unsigned p = 0;
    while (f >> name >> host >> p) port[name] = std::uint16_t(p);
  }
  if (port.size() < 2) die("cansimd did not write " + addresses);
  std::printf("socketcand bus, C++ clients on 127.0.0.1, %.0f s per run; cansimd CPU in %% of one core\n\n", seconds);
  std::printf("%-10s %-6s %8s %12s %12s %14s %9s %9s %6s\n", "scenario", "bus", "clients", "round trips/s",
              "bus frames/s", "client frames/s", "p50 us", "p99 us", "CPU");
  for (const char* bus : {"ideal", "timed"})
    for (int n : {1, 8}) {
      const Result r = ping_pong(bus, port[bus], n, seconds, pid);
      std::printf("%-10s %-6s %8d %12.0f %12.0f %14.0f %9.1f %9.1f %5.0f%%\n", "ping-pong", bus, n, r.rate, r.bus_fps,
                  r.client_fps, r.lat.p50_us, r.lat.p99_us, r.cpu * 100);
    }
  // Paced at 5,000 frames/s (about 60 % of the timed 1 Mbit/s bus): unpaced,
  // a sender fills its TCP buffers (megabytes on loopback) and the latency
  // measured is theirs; on an ideal bus it outruns a receiver, which is then
  // dropped (docs/socketcand.md "Bounds").
  std::printf("\n%-10s %-6s %10s %16s %20s %9s %9s %6s\n", "scenario", "bus", "receivers", "sent frames/s",
              "frames/s per receiver", "p50 us", "p99 us", "CPU");
  for (const char* bus : {"ideal", "timed"})
    for (int n : {1, 8}) {
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      const Result r = fan_out(bus, port[bus], n, seconds, pid, 5000);
      std::printf("%-10s %-6s %10d %16.0f %20.0f %9.1f %9.1f %5.0f%%\n", "fan-out", bus, n, r.bus_fps, r.client_fps,
                  r.lat.p50_us, r.lat.p99_us, r.cpu * 100);
    }
  kill(pid, SIGTERM);
  waitpid(pid, nullptr, 0);
  std::filesystem::remove_all(dir);
  return 0;
}
