#include "ctl/frame_source.hpp"

#include <arpa/inet.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>

#include "ctl/decode.hpp"
#include "io/socketcand.hpp"

namespace cansim::ctl {

namespace {

// A CAN_RAW socket on one interface, with the kernel's receive time of each frame.
class CanSocket : public FrameSource {
 public:
  explicit CanSocket(const std::string& interface) : interface_(interface) {
    fd_ = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
    if (fd_ < 0) throw Failure("cannot open a CAN socket: " + std::string(std::strerror(errno)));
    const unsigned index = if_nametoindex(interface.c_str());
    if (index == 0) {
      close(fd_);
      throw Failure("no CAN interface " + interface + " (the fleet's nodes on it are off the bus)");
    }
    const int on = 1;
    setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on);
    setsockopt(fd_, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on);  // each frame carries the drops so far
    // Room for bursts of a saturated bus (the kernel caps it at net.core.rmem_max).
    const int buffer = kReceiveBuffer;
    setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &buffer, sizeof buffer);
    const can_err_mask_t errors = CAN_ERR_MASK;
    setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &errors, sizeof errors);
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = int(index);
    if (bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) {
      const int e = errno;
      close(fd_);
      throw Failure("cannot listen on " + interface + ": " + std::strerror(e));
    }
  }
  ~CanSocket() override { close(fd_); }
  CanSocket(const CanSocket&) = delete;
  CanSocket& operator=(const CanSocket&) = delete;

  int fd() const override { return fd_; }
  const std::string& interface() const override { return interface_; }
  std::uint64_t dropped() const override { return dropped_; }

  bool receive(RawFrame& out) override {
    can_frame frame{};
    iovec iov{&frame, sizeof frame};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timeval)) + CMSG_SPACE(sizeof(std::uint32_t))];
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t n = recvmsg(fd_, &msg, 0);
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) return false;
      throw Failure("cannot read " + interface_ + ": " + std::strerror(errno));
    }
    out = RawFrame{};
    out.interface = interface_;
    out.time = receive_time(msg);
    count_drops(msg);
    out.extended = frame.can_id & CAN_EFF_FLAG;
    out.rtr = frame.can_id & CAN_RTR_FLAG;
    out.id = frame.can_id & (out.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
    out.error = frame.can_id & CAN_ERR_FLAG;
    if (out.error) out.id = frame.can_id & CAN_ERR_MASK;
    out.dlc = std::min<std::uint8_t>(frame.can_dlc, 8);
    std::memcpy(out.data, frame.data, out.dlc);
    return true;
  }

 private:
  static double receive_time(msghdr& msg) {
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SO_TIMESTAMP) continue;
      timeval tv;
      std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
      return double(tv.tv_sec) + double(tv.tv_usec) / 1e6;
    }
    timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return double(ts.tv_sec) + double(ts.tv_nsec) / 1e9;
  }

  // SO_RXQ_OVFL: the socket's drops so far, a 32-bit counter (it wraps).
  void count_drops(msghdr& msg) {
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SO_RXQ_OVFL) continue;
      std::uint32_t count = 0;
      std::memcpy(&count, CMSG_DATA(c), sizeof count);
      dropped_ += std::uint32_t(count - kernel_drops_);
      kernel_drops_ = count;
    }
  }

  static constexpr int kReceiveBuffer = 4 << 20;
  std::string interface_;
  int fd_ = -1;
  std::uint32_t kernel_drops_ = 0;
  std::uint64_t dropped_ = 0;
};

// A client of a bus cansimd serves in the socketcand protocol, in raw mode.
class SocketcandClient : public FrameSource {
 public:
  SocketcandClient(const std::string& bus, const std::string& host, std::uint16_t port, double timeout_s)
      : bus_(bus), where_(bus + " (socketcand " + host + ":" + std::to_string(port) + ")") {
    connect_to(host, port, timeout_s);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(std::int64_t(timeout_s * 1000));
    expect_message("hi", deadline);
    send("< open " + bus + " >");
    expect_message("ok", deadline);
    send("< rawmode >");
    expect_message("ok", deadline);
    send("< echo >");  // the server holds the bus's frames until the client speaks again
  }
  ~SocketcandClient() override { close(fd_); }
  SocketcandClient(const SocketcandClient&) = delete;
  SocketcandClient& operator=(const SocketcandClient&) = delete;

  int fd() const override { return fd_; }
  const std::string& interface() const override { return bus_; }

  bool receive(RawFrame& out) override {
    if (pending_.empty()) read_available();
    if (pending_.empty()) return false;
    out = pending_.front();
    pending_.pop_front();
    return true;
  }

 private:
  void connect_to(const std::string& host, std::uint16_t port, double timeout_s) {
    sockaddr_storage a{};
    socklen_t len = 0;
    auto* v4 = reinterpret_cast<sockaddr_in*>(&a);
    auto* v6 = reinterpret_cast<sockaddr_in6*>(&a);
    if (inet_pton(AF_INET, host.c_str(), &v4->sin_addr) == 1) {
      v4->sin_family = AF_INET, v4->sin_port = htons(port), len = sizeof *v4;
    } else if (inet_pton(AF_INET6, host.c_str(), &v6->sin6_addr) == 1) {
      v6->sin6_family = AF_INET6, v6->sin6_port = htons(port), len = sizeof *v6;
    } else {
      throw Failure(where_ + ": not a numeric address");
    }
    fd_ = socket(a.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw Failure(where_ + ": " + std::strerror(errno));
    if (connect(fd_, reinterpret_cast<sockaddr*>(&a), len) < 0 && errno != EINPROGRESS) fail(errno);
    pollfd p{fd_, POLLOUT, 0};
    if (poll(&p, 1, int(timeout_s * 1000)) <= 0) fail(ETIMEDOUT);
    int err = 0;
    socklen_t elen = sizeof err;
    getsockopt(fd_, SOL_SOCKET, SO_ERROR, &err, &elen);
    if (err) fail(err);
  }
  [[noreturn]] void fail(int err) {
    close(fd_);
    fd_ = -1;
    throw Failure("cannot connect to " + where_ + ": " + std::strerror(err));
  }
  void send(const std::string& text) {
    if (::send(fd_, text.data(), text.size(), MSG_NOSIGNAL) != ssize_t(text.size()))
      throw Failure(where_ + ": " + std::strerror(errno));
  }
  // Reads what waits; false at the end of the stream.
  bool read_some() {
    char buf[16384];
    const ssize_t n = recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
    if (n == 0) return false;
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) return true;
      throw Failure("cannot read " + where_ + ": " + std::strerror(errno));
    }
    reader_.append(std::string_view(buf, std::size_t(n)));
    return true;
  }
  void expect_message(const std::string& word, std::chrono::steady_clock::time_point deadline) {
    std::string body;
    while (!reader_.next(body)) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      pollfd p{fd_, POLLIN, 0};
      if (left.count() <= 0 || poll(&p, 1, int(left.count())) <= 0)
        throw Failure(where_ + ": no < " + word + " > from the server");
      if (!read_some()) throw Failure(where_ + ": the server closed the connection");
    }
    const std::size_t a = body.find_first_not_of(' '), b = body.find_last_not_of(' ');
    const std::string got = a == std::string::npos ? "" : body.substr(a, b - a + 1);
    if (got != word) throw Failure(where_ + ": expected < " + word + " >, got < " + got + " >");
  }
  void read_available() {
    if (!read_some())
      throw Failure(where_ +
                    ": the server closed the connection (cansimd stopped, or dropped this client for "
                    "reading too slowly: its journal says which)");
    std::string body;
    while (reader_.next(body)) {
      CanFrame f;
      double t = 0;
      if (!io::socketcand::parse_frame_message(body, f, t)) continue;  // `< echo >` and the like
      RawFrame r;
      r.time = t;
      r.interface = bus_;
      r.id = f.id;
      r.extended = f.extended();
      r.rtr = f.rtr();
      r.dlc = f.dlc;
      std::memcpy(r.data, f.data, 8);
      pending_.push_back(r);
    }
  }

  std::string bus_, where_;
  int fd_ = -1;
  io::socketcand::MessageReader reader_;
  std::deque<RawFrame> pending_;
};

}  // namespace

SocketcandAddresses socketcand_addresses(Connection& connection) {
  std::vector<BusStats> rows = read_bus_stats(connection.call(kFleetPath, kFleetInterface, "GetBusStatistics").get());
  MessagePtr reply = connection.call(kFleetPath, kPropertiesInterface, "Get",
                                     {Value(std::string(kFleetInterface)), Value(std::string("SocketcandBuses"))});
  read_socketcand_buses(reply.get(), rows);
  SocketcandAddresses out;
  for (const BusStats& b : rows)
    if (b.transport == "socketcand") out[b.name] = {b.listen_host, b.listen_port};
  return out;
}

std::unique_ptr<FrameSource> open_frame_source(const std::string& name, const SocketcandAddresses& served,
                                               double timeout_s) {
  const auto it = served.find(name);
  if (it == served.end()) return std::make_unique<CanSocket>(name);
  if (it->second.second == 0) throw Failure(name + ": cansimd does not listen for its socketcand clients now");
  return std::make_unique<SocketcandClient>(name, it->second.first, it->second.second, timeout_s);
}

}  // namespace cansim::ctl
