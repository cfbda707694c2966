#include "control/endpoints.hpp"

#include <grp.h>
#include <spdlog/spdlog.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace cansim::control {

namespace {
constexpr int kMessagesPerPass = 32;     // per connection and loop pass
constexpr int kAcceptsPerPass = 64;
// A pass serves connections (and accepts new ones) for at most this long,
// then the nodes run: a client whose calls are cheap gets many per pass, one
// whose calls are costly (AddNodes loads a profile) one per pass.
constexpr TimeUs kPassBudgetUs = 2'000;
// Calls wake the loop at most once per this period; between such wake-ups a
// call waits for the loop's next pass, at most this long. A busy fleet thus
// serves a stream of calls with the passes it makes anyway; a single call
// is answered at once.
constexpr TimeUs kCallWaitUs = 5'000;

std::runtime_error sys_error(const std::string& what, int err) {
  return std::runtime_error(what + ": " + std::strerror(err));
}

bool exists(const char* path) { return path && access(path, F_OK) == 0; }

// A client that went away before its connection was set up is no news.
bool client_gone(int err) { return err == ECONNRESET || err == EPIPE || err == ENOTCONN; }

// "client pid 4242 uid 1000" (the socket's peer credentials), for the journal.
std::string describe_client(int fd) {
  ucred cred{};
  socklen_t len = sizeof cred;
  if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0) return "client";
  return "client pid " + std::to_string(cred.pid) + " uid " + std::to_string(cred.uid);
}

// The client closed its end before it was accepted (nothing to read but the end).
bool closed_already(int fd) {
  char byte;
  return ::recv(fd, &byte, 1, MSG_PEEK | MSG_DONTWAIT) == 0;
}

std::uint64_t queued(sd_bus* bus) {
  std::uint64_t n = 0;
  return sd_bus_get_n_queued_write(bus, &n) >= 0 ? n : 0;
}
}  // namespace

// At most one warning line per period; the ones held back are counted in the next.
struct ControlEndpoints::Throttle {
  TimeUs next = 0;
  std::uint64_t held = 0;
  void warn(TimeUs now, std::string line) {
    if (now < next) {
      ++held;
      return;
    }
    if (held)
      line += " (and " + std::to_string(held) + " more such in the " +
              std::to_string(limits::kWarningPeriodUs / 1'000'000) + " s before)";
    spdlog::warn("{}", line);
    held = 0;
    next = now + limits::kWarningPeriodUs;
  }
};

std::string default_control_socket() {
  if (const char* d = std::getenv("RUNTIME_DIRECTORY"); d && *d) {
    std::string dir = d;
    dir = dir.substr(0, dir.find(':'));  // RuntimeDirectory= may list several
    return dir + "/control";
  }
  if (const char* x = std::getenv("XDG_RUNTIME_DIR"); x && *x) return std::string(x) + "/cansimd/control";
  if (geteuid() == 0) return "/run/cansimd/control";
  return "/tmp/cansimd-" + std::to_string(geteuid()) + "/control";
}

struct ControlEndpoints::Connection : io::FdHandler {
  sd_bus* bus = nullptr;
  bool peer = false;
  int fd = -1;
  std::uint32_t mask = 0;
  bool ready = true;  // epoll reported the fd (or it is new): process() reads it
  TimeUs since = 0;   // accepted (CLOCK_MONOTONIC µs)
  bool refusing = false;  // over --max-clients: answers why, then goes
  bool answered = false;  // refusing: the first call has its answer
  const std::string* refusal = nullptr;
  void on_events(std::uint32_t) override { ready = true; }
};

struct ControlEndpoints::Listener : io::FdHandler {
  explicit Listener(ControlEndpoints& e) : owner(e) {}
  void on_events(std::uint32_t) override { owner.accept_clients(); }
  ControlEndpoints& owner;
  int fd = -1;
};

ControlEndpoints::ControlEndpoints(io::EventLoop& loop, ControlService& service, std::size_t max_clients)
    : loop_(loop),
      service_(service),
      max_clients_(max_clients),
      refusal_("cansimd serves at most " + std::to_string(max_clients) +
               " control clients at once (cansimd --max-clients); try again when one has disconnected"),
      warn_refused_(std::make_unique<Throttle>()),
      warn_slow_(std::make_unique<Throttle>()),
      warn_handshake_(std::make_unique<Throttle>()),
      warn_failed_(std::make_unique<Throttle>()) {}

ControlEndpoints::~ControlEndpoints() {
  while (!connections_.empty()) drop(*connections_.back());
  if (listener_) {
    loop_.remove_deferred(listener_->fd);
    ::close(listener_->fd);
    ::unlink(socket_path_.c_str());
  }
}

void ControlEndpoints::listen(const std::string& path) {
  sockaddr_un addr{};
  if (path.size() >= sizeof addr.sun_path) throw std::runtime_error(path + ": socket path too long");
  std::error_code ec;
  std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty() && !std::filesystem::exists(parent, ec)) {
    std::filesystem::create_directories(parent, ec);
    if (ec) throw std::runtime_error(parent.string() + ": " + ec.message());
    ::chmod(parent.c_str(), 0755);
  }
  int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) throw sys_error("socket", errno);
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size());
  ::unlink(path.c_str());  // a stale socket of an earlier run
  // Created 0660 from the start: no window in which others could connect.
  mode_t old = ::umask(0117);
  int r = ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  ::umask(old);
  if (r < 0 || ::listen(fd, SOMAXCONN) < 0) {  // a burst of connects waits in the backlog, not refused
    int err = errno;
    ::close(fd);
    throw sys_error(path, err);
  }
  // Run as group cansim (the systemd units), the socket is the group's
  // already: no chown, which their system call filter refuses.
  struct stat st{};
  if (const group* g = ::getgrnam("cansim"); g && (::stat(path.c_str(), &st) != 0 || st.st_gid != g->gr_gid)) {
    if (::chown(path.c_str(), uid_t(-1), g->gr_gid) < 0)
      spdlog::warn("{}: cannot give the control socket to group cansim: {}", path, std::strerror(errno));
  }
  listener_ = std::make_unique<Listener>(*this);
  listener_->fd = fd;
  loop_.add_deferred(fd, EPOLLIN, listener_.get());
  socket_path_ = path;
}

// A bounded number per pass: a connect flood must not hold the loop (the
// rest wait in the listen backlog for the next passes).
void ControlEndpoints::accept_clients() {
  for (int accepted = 0; accepted < kAcceptsPerPass && io::monotonic_now() < pass_end_; ++accepted) {
    int fd = ::accept4(listener_->fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
        warn_failed_->warn(io::monotonic_now(), std::string("control socket: accept: ") + std::strerror(errno));
      return;
    }
    if (closed_already(fd)) {  // a connect / close loop costs an accept, not a connection
      ::close(fd);
      continue;
    }
    const std::size_t peers = std::count_if(connections_.begin(), connections_.end(),
                                            [](const auto& c) { return c->peer && !c->refusing; });
    if (peers >= max_clients_) {
      refuse(fd, peers);
      continue;
    }
    if (sd_bus* bus = serve_fd(fd)) add_connection(bus, true);
  }
}

// A peer-to-peer server connection on an accepted socket, or nullptr (closed).
sd_bus* ControlEndpoints::serve_fd(int fd) {
  sd_bus* bus = nullptr;
  sd_id128_t id;
  sd_id128_randomize(&id);
  int r = sd_bus_new(&bus);
  if (r >= 0) r = sd_bus_set_fd(bus, fd, fd);
  if (r >= 0) r = sd_bus_set_server(bus, 1, id);
  if (r >= 0) r = sd_bus_set_anonymous(bus, 0);
  if (r >= 0) r = sd_bus_negotiate_creds(bus, 1, SD_BUS_CREDS_PID | SD_BUS_CREDS_UID | SD_BUS_CREDS_EUID);
  if (r >= 0) r = sd_bus_start(bus);
  if (r >= 0) {
    // sd-bus asks for 8 MiB of kernel send buffer (and gets it as root):
    // what a client does not read stays within limits::kSocketBufferBytes.
    const int bytes = int(limits::kSocketBufferBytes);
    ::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &bytes, sizeof bytes);
    return bus;
  }
  const std::string line = std::string("control socket: cannot serve a client: ") + std::strerror(-r);
  if (client_gone(-r)) spdlog::debug("{}", line);
  else warn_failed_->warn(io::monotonic_now(), line);
  if (bus) sd_bus_close_unref(bus);
  else ::close(fd);
  return nullptr;
}

// One client too many: it is told why (its first call's answer) and closed;
// beyond limits::kRefusing such at once, it is closed at once.
void ControlEndpoints::refuse(int fd, std::size_t peers) {
  warn_refused_->warn(io::monotonic_now(), "control socket: " + std::to_string(peers) +
                                               " clients connected already (--max-clients " +
                                               std::to_string(max_clients_) + "): refusing another");
  const std::size_t refusing =
      std::count_if(connections_.begin(), connections_.end(), [](const auto& c) { return c->refusing; });
  if (refusing >= limits::kRefusing) {
    ::close(fd);
    return;
  }
  if (sd_bus* bus = serve_fd(fd)) add_connection(bus, true, true);
}

std::string ControlEndpoints::connect_bus(BusChoice choice) {
  if (choice == BusChoice::kNone) return {};
  const bool root = geteuid() == 0;
  if (choice == BusChoice::kAuto) {
    const char* sys = std::getenv("DBUS_SYSTEM_BUS_ADDRESS");
    if (root && (sys || exists("/run/dbus/system_bus_socket"))) choice = BusChoice::kSystem;
    else if (std::getenv("DBUS_SESSION_BUS_ADDRESS")) choice = BusChoice::kUser;
    else if (const char* x = std::getenv("XDG_RUNTIME_DIR"); x && exists((std::string(x) + "/bus").c_str()))
      choice = BusChoice::kUser;
    else return {};
  }
  const bool system = choice == BusChoice::kSystem;
  const char* what = system ? "system bus" : "user bus";
  sd_bus* bus = nullptr;
  int r = system ? sd_bus_open_system(&bus) : sd_bus_open_user(&bus);
  if (r >= 0) r = sd_bus_request_name(bus, kBusName, 0);
  if (r < 0) {
    if (bus) sd_bus_flush_close_unref(bus);
    throw std::runtime_error(std::string(what) + ": cannot serve " + kBusName + ": " + std::strerror(-r));
  }
  add_connection(bus, false);
  return what;
}

ControlEndpoints::Connection* ControlEndpoints::add_connection(sd_bus* bus, bool peer, bool refusing) {
  auto c = std::make_unique<Connection>();
  c->bus = bus;
  c->peer = peer;
  c->fd = sd_bus_get_fd(bus);
  c->since = io::monotonic_now();
  c->refusing = refusing;
  c->refusal = &refusal_;
  int r = 0;
  if (!refusing) {
    r = service_.attach(bus, peer);
  } else {  // every call answered with why, nothing served
    r = sd_bus_add_filter(bus, nullptr, [](sd_bus_message* m, void* userdata, sd_bus_error*) -> int {
      auto& self = *static_cast<Connection*>(userdata);
      if (sd_bus_message_is_method_call(m, nullptr, nullptr) <= 0) return 0;
      self.answered = true;
      return sd_bus_reply_method_errorf(m, SD_BUS_ERROR_LIMITS_EXCEEDED, "%s", self.refusal->c_str());
    }, c.get());
  }
  if (r < 0 || c->fd < 0) {
    spdlog::warn("control: cannot serve a connection: {}", std::strerror(r < 0 ? -r : EBADF));
    sd_bus_close_unref(bus);
    return nullptr;
  }
  loop_.add_deferred(c->fd, 0, c.get());
  connections_.push_back(std::move(c));
  return connections_.back().get();
}

const char* ControlEndpoints::must_go(const Connection& c, TimeUs now, Throttle** warning) const {
  *warning = nullptr;
  if (c.refusing)
    return (c.answered && queued(c.bus) == 0) || now - c.since >= limits::kRefusalLingerUs ? "refused" : nullptr;
  if (!c.peer) return nullptr;
  if (sd_bus_is_ready(c.bus) <= 0 && now - c.since >= limits::kAuthTimeoutUs) {
    *warning = warn_handshake_.get();
    return "did not finish the D-Bus handshake in time";
  }
  if (queued(c.bus) >= limits::kQueuedMessages) {
    *warning = warn_slow_.get();
    return "reads too slowly: its answers and signals waiting reached the bound";
  }
  return nullptr;
}

void ControlEndpoints::drop(Connection& c) {
  loop_.remove_deferred(c.fd);
  if (!c.refusing) service_.detach(c.bus);
  if (c.peer) sd_bus_close_unref(c.bus);
  else sd_bus_flush_close_unref(c.bus);
  std::erase_if(connections_, [&](const auto& p) { return p.get() == &c; });
}

void ControlEndpoints::rearm(Connection& c) {
  int events = sd_bus_get_events(c.bus);
  std::uint32_t mask = 0;
  if (events > 0) {
    if (events & POLLIN) mask |= EPOLLIN;
    if (events & POLLOUT) mask |= EPOLLOUT;
  }
  if (mask != c.mask) {
    loop_.modify_deferred(c.fd, mask, &c);
    c.mask = mask;
  }
}

// Every connection is looked at after every pass, but read only when epoll
// reported its fd or sd-bus says it has work (timeout due, e.g. 0 for a
// message it already buffered): an idle connection costs no syscall.
TimeUs ControlEndpoints::process() {
  const TimeUs now = io::monotonic_now();
  pass_end_ = now + kPassBudgetUs;
  loop_.poll_deferred();  // marks the connections with input, accepts new clients
  TimeUs next = kNever;
  const Connection* spent = nullptr;  // the connection being served when the pass's time ran out
  for (std::size_t i = 0; i < connections_.size();) {
    Connection& c = *connections_[i];
    std::uint64_t timeout = UINT64_MAX;
    if (sd_bus_get_timeout(c.bus, &timeout) < 0) timeout = 0;
    if ((c.ready || TimeUs(timeout) <= now) && io::monotonic_now() >= pass_end_) {
      c.ready = true;  // its turn comes after the nodes ran
      next = 0;
    } else if (c.ready || TimeUs(timeout) <= now) {
      c.ready = false;
      last_served_ = now;
      int r = 0;
      int n = 0;
      while (n < kMessagesPerPass && io::monotonic_now() < pass_end_ && (r = sd_bus_process(c.bus, nullptr)) > 0) ++n;
      if (r < 0 || !sd_bus_is_open(c.bus)) {
        if (!c.peer) spdlog::warn("control: lost the D-Bus connection: {}", std::strerror(r < 0 ? -r : ECONNRESET));
        drop(c);  // erases connections_[i]
        continue;
      }
      if (n == kMessagesPerPass || (r > 0 && io::monotonic_now() >= pass_end_)) {  // more: after the nodes ran
        c.ready = true;
        next = 0;
        if (!spent && io::monotonic_now() >= pass_end_) spent = &c;
      }
      if (sd_bus_get_timeout(c.bus, &timeout) < 0) timeout = 0;
    }
    Throttle* warning = nullptr;
    if (const char* why = must_go(c, now, &warning)) {
      if (warning) warning->warn(now, "control: " + describe_client(c.fd) + " dropped: " + why);
      if (spent == &c) spent = nullptr;
      drop(c);  // erases connections_[i]
      continue;
    }
    if (!c.peer && queued(c.bus) >= limits::kQueuedMessages)
      warn_slow_->warn(now, "control: the D-Bus daemon reads too slowly: signals to subscribers dropped");
    rearm(c);  // signals sent between passes may have left output queued
    if (timeout != UINT64_MAX) next = std::min(next, TimeUs(timeout));
    if (c.refusing) next = std::min(next, c.since + limits::kRefusalLingerUs);
    else if (c.peer && sd_bus_is_ready(c.bus) <= 0) next = std::min(next, c.since + limits::kAuthTimeoutUs);
    ++i;
  }
  // Round robin: the next pass starts with the connections after the one the time ran out on.
  if (spent) {
    auto it = std::find_if(connections_.begin(), connections_.end(), [&](const auto& p) { return p.get() == spent; });
    if (it != connections_.end()) std::rotate(connections_.begin(), it + 1, connections_.end());
  }
  return next;
}

void ControlEndpoints::before_sleep(TimeUs next_pass) {
  const TimeUs now = io::monotonic_now();
  loop_.allow_deferred_wakeup(next_pass == kNever || next_pass - now > kCallWaitUs ||
                              now - last_served_ >= kCallWaitUs);
}

}  // namespace cansim::control
