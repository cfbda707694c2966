#include "io/socketcand_server.hpp"

#include <arpa/inet.h>
#include <linux/can.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>

#include "io/failure.hpp"

#include "io/can_interface.hpp"

namespace cansim::io {

namespace {

constexpr int kBacklog = 64;
constexpr int kAcceptsPerWake = 64;

socketcand::Stamp realtime_now() {
  timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  return {std::int64_t(ts.tv_sec), std::int32_t(ts.tv_nsec / 1000)};
}

// A numeric address as a socket address; false when it is none.
bool socket_address(const std::string& host, std::uint16_t port, sockaddr_storage& out, socklen_t& len) {
  out = {};
  auto* v4 = reinterpret_cast<sockaddr_in*>(&out);
  if (inet_pton(AF_INET, host.c_str(), &v4->sin_addr) == 1) {
    v4->sin_family = AF_INET;
    v4->sin_port = htons(port);
    len = sizeof *v4;
    return true;
  }
  auto* v6 = reinterpret_cast<sockaddr_in6*>(&out);
  if (inet_pton(AF_INET6, host.c_str(), &v6->sin6_addr) == 1) {
    v6->sin6_family = AF_INET6;
    v6->sin6_port = htons(port);
    len = sizeof *v6;
    return true;
  }
  return false;
}

std::string endpoint_text(const std::string& host, std::uint16_t port) {
  const bool v6 = host.find(':') != std::string::npos;
  return (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

std::string peer_text(int fd) {
  sockaddr_storage a{};
  socklen_t len = sizeof a;
  if (getpeername(fd, reinterpret_cast<sockaddr*>(&a), &len) < 0) return "?";
  char text[INET6_ADDRSTRLEN] = "?";
  if (a.ss_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
    inet_ntop(AF_INET, &v4->sin_addr, text, sizeof text);
    return endpoint_text(text, ntohs(v4->sin_port));
  }
  const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
  inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof text);
  return endpoint_text(text, ntohs(v6->sin6_port));
}

}  // namespace

// One journal line per kind per period; the lines held back are counted.
struct SocketcandServer::Throttle {
  TimeUs period = 0;
  TimeUs last = -1;
  std::uint64_t held = 0;
  // The line to log now ("" when held back).
  std::string pass(const std::string& line, TimeUs now) {
    if (last >= 0 && now - last < period) {
      ++held;
      return {};
    }
    std::string out = line;
    if (held) out += " (and " + std::to_string(held) + " more since the last such line)";
    held = 0;
    last = now;
    return out;
  }
};

struct SocketcandServer::Listener : FdHandler {
  explicit Listener(SocketcandServer& s) : server(s) {}
  void on_events(std::uint32_t) override { server.accept_clients(); }
  SocketcandServer& server;
};

struct SocketcandServer::Client : FdHandler, socketcand::Session::Sink {
  Client(SocketcandServer& s, int f, Participant p, std::string who)
      : server(s), fd(f), id(p), peer(std::move(who)), session(s.settings_.bus) {}
  ~Client() override {
    if (fd >= 0) ::close(fd);
  }
  void on_events(std::uint32_t events) override { server.on_client(*this, events); }
  // Session::Sink: the client's frame goes to the bus.
  void frame(const CanFrame& f) override {
    ++server.stats_.frames_in;
    ++in_flight;
    if (!server.core_->submit(server.bus_, f, id, server.now_())) {
      --in_flight;
      ++server.stats_.frames_lost;
    }
  }
  std::size_t unread() const { return out.size() - sent; }

  SocketcandServer& server;
  int fd;
  Participant id;
  std::string peer;
  socketcand::Session session;
  std::string out;  // answers and frames not yet written; out[0, sent) was
  std::size_t sent = 0;
  std::size_t in_flight = 0;  // its frames waiting for the wire
  std::uint32_t mask = 0;     // epoll interest now
  bool raw_seen = false;
  TimeUs hold_until = kNever;  // the rawmode hold: frames after hold_mark wait
  std::size_t hold_mark = 0;
  std::uint64_t hold_messages = 0;
  bool dead = false;
};

SocketcandServer::SocketcandServer(EventLoop& loop, SocketcandSettings settings)
    : loop_(loop),
      settings_(std::move(settings)),
      wall_clock_(realtime_now),
      warn_refused_(std::make_unique<Throttle>()),
      warn_slow_(std::make_unique<Throttle>()) {
  warn_refused_->period = warn_slow_->period = settings_.warning_period;
}

SocketcandServer::~SocketcandServer() { close(); }

void SocketcandServer::attach(LoopCore& core, BusId bus, Clock now, Log log) {
  core_ = &core;
  bus_ = bus;
  now_ = std::move(now);
  log_ = std::move(log);
}

void SocketcandServer::log(Level level, const std::string& line) const {
  if (log_ && !line.empty()) log_(level, line);
}

bool SocketcandServer::listen() {
  close();
  sockaddr_storage addr;
  socklen_t len = 0;
  const std::string where = endpoint_text(settings_.host, settings_.port);
  if (!socket_address(settings_.host, settings_.port, addr, len)) {
    error_ = where + ": not a numeric IPv4 or IPv6 address";
    return false;
  }
  const int fd = ::socket(addr.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error_ = failure(where + ": socket", errno);
    return false;
  }
  const int on = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), len) < 0 || ::listen(fd, kBacklog) < 0) {
    error_ = failure(where, errno);
    ::close(fd);
    return false;
  }
  sockaddr_storage bound{};
  socklen_t blen = sizeof bound;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &blen);
  port_ = ntohs(bound.ss_family == AF_INET ? reinterpret_cast<sockaddr_in*>(&bound)->sin_port
                                           : reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port);
  listen_fd_ = fd;
  listener_ = std::make_unique<Listener>(*this);
  if (!loop_.add(listen_fd_, EPOLLIN, listener_.get())) {
    error_ = where + ": " + loop_.error();
    close();
    return false;
  }
  return true;
}

void SocketcandServer::close() {
  clients_.clear();  // their destructors close the sockets (and so leave epoll)
  if (listen_fd_ >= 0) ::close(listen_fd_);
  listen_fd_ = -1;
  listener_.reset();
  update_pacer();
}

bool SocketcandServer::carries() const {
  return std::any_of(clients_.begin(), clients_.end(), [](const auto& c) { return !c->dead; });
}

void SocketcandServer::update_pacer() {
  if (core_ && core_->bus_valid(bus_)) core_->update_pacer(bus_);
}

std::size_t SocketcandServer::clients() const {
  return std::size_t(std::count_if(clients_.begin(), clients_.end(), [](const auto& c) { return !c->dead; }));
}

Participant SocketcandServer::next_participant() {
  last_participant_ = last_participant_ + 1 >= kReplayParticipant ? 1 : last_participant_ + 1;
  return last_participant_;
}

void SocketcandServer::accept_clients() {
  for (int i = 0; i < kAcceptsPerWake; ++i) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;  // EAGAIN, or a connection gone before we took it
    const std::string peer = peer_text(fd);
    if (clients() >= settings_.max_clients) {
      refuse(fd, peer);
      continue;
    }
    const int on = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    const int buffer = int(settings_.send_buffer);
    if (buffer > 0) ::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &buffer, sizeof buffer);
    auto client = std::make_unique<Client>(*this, fd, next_participant(), peer);
    client->out.assign(socketcand::Session::greeting());
    client->mask = EPOLLIN;
    if (!loop_.add(fd, EPOLLIN, client.get())) {
      log(Level::kWarn, settings_.bus + ": socketcand client " + peer + " refused: " + loop_.error());
      continue;  // its destructor closes the socket
    }
    ++stats_.clients_served;
    log(Level::kDebug, settings_.bus + ": socketcand client " + peer + " connected");
    clients_.push_back(std::move(client));
    update_pacer();  // the loop paces the bus while a client is connected
    write_client(*clients_.back(), now_());
  }
}

void SocketcandServer::refuse(int fd, const std::string& peer) {
  ++stats_.clients_refused;
  const std::string text = "< error cansimd serves at most " + std::to_string(settings_.max_clients) +
                           " socketcand clients on " + settings_.bus + " at once >";
  (void)!::send(fd, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
  ::close(fd);
  log(Level::kWarn, warn_refused_->pass(settings_.bus + ": socketcand client " + peer + " refused: " +
                                            std::to_string(settings_.max_clients) + " clients are connected",
                                        now_()));
}

void SocketcandServer::on_client(Client& c, std::uint32_t events) {
  if (c.dead) return;
  if (events & EPOLLOUT) write_client(c, now_());
  if (!c.dead && (events & (EPOLLIN | EPOLLHUP | EPOLLERR))) read_client(c);
  update_interest(c);
}

void SocketcandServer::read_client(Client& c) {
  // What was due before these frames arrived happens first.
  const TimeUs now = now_();
  core_->run_due(now);
  char buf[2048];
  std::size_t left = settings_.read_per_pass;
  while (left > 0 && c.in_flight < settings_.max_in_flight && !c.session.closed()) {
    const ssize_t n = ::recv(c.fd, buf, std::min(left, sizeof buf), MSG_DONTWAIT);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
      log(Level::kDebug, settings_.bus + ": socketcand client " + c.peer + " disconnected");
      c.dead = true;
      reap_pending_ = true;
      return;
    }
    if (n < 0) break;
    left -= std::size_t(n);
    const std::uint64_t errors = c.session.errors();
    c.session.feed(std::string_view(buf, std::size_t(n)), c.out, c);
    stats_.errors_sent += c.session.errors() - errors;
    if (!c.raw_seen && c.session.receives_frames()) {
      c.raw_seen = true;  // the answer `< ok >` goes now, the frames after it wait
      c.hold_until = now + settings_.rawmode_hold;
      c.hold_mark = c.out.size();
      c.hold_messages = c.session.messages();
    }
  }
}

void SocketcandServer::write_client(Client& c, TimeUs now) {
  if (c.hold_until != kNever && (c.session.messages() > c.hold_messages || now >= c.hold_until)) c.hold_until = kNever;
  const std::size_t end = c.hold_until == kNever ? c.out.size() : std::min(c.hold_mark, c.out.size());
  while (c.sent < end) {
    const ssize_t n = ::send(c.fd, c.out.data() + c.sent, end - c.sent, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) break;
      c.dead = true;
      reap_pending_ = true;
      return;
    }
    c.sent += std::size_t(n);
  }
  if (c.sent == c.out.size()) {
    c.out.clear();
    c.hold_mark -= std::min(c.hold_mark, c.sent);
    c.sent = 0;
    if (c.session.closed()) {
      c.dead = true;  // its last answer is written
      reap_pending_ = true;
    }
  } else if (c.sent > c.out.size() / 2) {
    c.out.erase(0, c.sent);
    c.hold_mark -= std::min(c.hold_mark, c.sent);
    c.sent = 0;
  }
}

void SocketcandServer::update_interest(Client& c) {
  if (c.dead) return;
  const bool waiting = c.sent < (c.hold_until == kNever ? c.out.size() : std::min(c.hold_mark, c.out.size()));
  const std::uint32_t want =
      (c.in_flight < settings_.max_in_flight && !c.session.closed() ? EPOLLIN : 0u) | (waiting ? EPOLLOUT : 0u);
  if (want == c.mask) return;
  if (!loop_.modify(c.fd, want, &c)) return drop(c, loop_.error());
  c.mask = want;
}

void SocketcandServer::drop(Client& c, const std::string& why) {
  if (c.dead) return;
  c.dead = true;
  reap_pending_ = true;
  ++stats_.clients_dropped;
  log(Level::kWarn, warn_slow_->pass(settings_.bus + ": socketcand client " + c.peer + " dropped: " + why, now_()));
}

void SocketcandServer::transmit_from(const CanFrame& frame, Participant from) {
  char text[socketcand::kMaxFrameText];
  const bool from_client = deliver([&] { return socketcand::format_frame(frame, wall_clock_(), text); }, text, from);
  stats_.frames_out += !from_client;  // a client's frame was counted in frames_in
}

void SocketcandServer::error(BusError e) {
  char text[socketcand::kMaxFrameText];
  const std::uint32_t error_class = error_frame(e).can_id & CAN_EFF_MASK;
  deliver([&] { return socketcand::format_error(error_class, wall_clock_(), text); }, text, 0);
  ++stats_.errors_out;
}

template <typename Format>
bool SocketcandServer::deliver(Format&& format, char* text, Participant from) {
  std::size_t len = 0;
  bool from_client = false;
  for (auto& cp : clients_) {
    Client& c = *cp;
    if (c.dead) continue;
    if (c.id == from) {
      from_client = true;
      if (c.in_flight > 0 && c.in_flight-- == settings_.max_in_flight) update_interest(c);  // it may send again
      continue;
    }
    if (!c.session.receives_frames()) continue;
    if (len == 0) len = format();
    c.out.append(text, len);
    // During the rawmode hold nothing goes to its socket: its buffer's share is here.
    const std::size_t bound = settings_.max_unread + (c.hold_until != kNever ? settings_.send_buffer : 0);
    if (c.unread() <= bound) continue;
    // One pass may carry more than the bound (a replay's instant on an ideal
    // bus, a timed bus catching up): the socket's buffer takes it first.
    write_client(c, now_());
    if (!c.dead && c.unread() > bound)
      drop(c, "reads too slowly (" + std::to_string(settings_.max_unread / 1024) +
                  " KiB unread beyond its socket buffer)");
  }
  return from_client;
}

void SocketcandServer::flush() {
  const TimeUs now = now_ ? now_() : 0;
  for (auto& c : clients_) {
    if (c->dead) continue;
    if (c->unread() > 0) write_client(*c, now);
    update_interest(*c);
  }
  if (reap_pending_) reap();
}

void SocketcandServer::reap() {
  reap_pending_ = false;
  std::erase_if(clients_, [this](const std::unique_ptr<Client>& c) {
    if (c->dead) loop_.remove(c->fd);
    return c->dead;
  });
  update_pacer();
}

TimeUs SocketcandServer::next_deadline() const {
  TimeUs t = kNever;
  for (const auto& c : clients_)
    if (!c->dead && c->hold_until != kNever && c->sent < c->out.size()) t = std::min(t, c->hold_until);
  return t;
}

}  // namespace cansim::io
