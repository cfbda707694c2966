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
constexpr std::size_t kMaxClients = 64;  // peer connections at once
// Calls wake the loop at most once per this period; between such wake-ups a
// call waits for the loop's next pass, at most this long. A busy fleet thus
// serves a stream of calls with the passes it makes anyway; a single call
// is answered at once.
constexpr TimeUs kCallWaitUs = 5'000;

std::runtime_error sys_error(const std::string& what, int err) {
  return std::runtime_error(what + ": " + std::strerror(err));
}

bool exists(const char* path) { return path && access(path, F_OK) == 0; }
}  // namespace

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
  void on_events(std::uint32_t) override { ready = true; }
};

struct ControlEndpoints::Listener : io::FdHandler {
  explicit Listener(ControlEndpoints& e) : owner(e) {}
  void on_events(std::uint32_t) override { owner.accept_clients(); }
  ControlEndpoints& owner;
  int fd = -1;
};

ControlEndpoints::ControlEndpoints(io::EventLoop& loop, ControlService& service) : loop_(loop), service_(service) {}

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
  if (r < 0 || ::listen(fd, 16) < 0) {
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

void ControlEndpoints::accept_clients() {
  for (;;) {
    int fd = ::accept4(listener_->fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
        spdlog::warn("control socket: accept: {}", std::strerror(errno));
      return;
    }
    std::size_t peers = std::count_if(connections_.begin(), connections_.end(), [](const auto& c) { return c->peer; });
    if (peers >= kMaxClients) {
      spdlog::warn("control socket: {} clients already connected, refusing another", peers);
      ::close(fd);
      continue;
    }
    sd_bus* bus = nullptr;
    sd_id128_t id;
    sd_id128_randomize(&id);
    int r = sd_bus_new(&bus);
    if (r >= 0) r = sd_bus_set_fd(bus, fd, fd);
    if (r >= 0) r = sd_bus_set_server(bus, 1, id);
    if (r >= 0) r = sd_bus_set_anonymous(bus, 0);
    if (r >= 0) r = sd_bus_negotiate_creds(bus, 1, SD_BUS_CREDS_PID | SD_BUS_CREDS_UID | SD_BUS_CREDS_EUID);
    if (r >= 0) r = sd_bus_start(bus);
    if (r < 0) {
      spdlog::warn("control socket: cannot serve a client: {}", std::strerror(-r));
      if (bus) sd_bus_close_unref(bus);
      else ::close(fd);
      continue;
    }
    add_connection(bus, true);
  }
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

void ControlEndpoints::add_connection(sd_bus* bus, bool peer) {
  auto c = std::make_unique<Connection>();
  c->bus = bus;
  c->peer = peer;
  c->fd = sd_bus_get_fd(bus);
  int r = service_.attach(bus, peer);
  if (r < 0 || c->fd < 0) {
    spdlog::warn("control: cannot serve a connection: {}", std::strerror(r < 0 ? -r : EBADF));
    sd_bus_close_unref(bus);
    return;
  }
  loop_.add_deferred(c->fd, 0, c.get());
  connections_.push_back(std::move(c));
}

void ControlEndpoints::drop(Connection& c) {
  loop_.remove_deferred(c.fd);
  service_.detach(c.bus);
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
  loop_.poll_deferred();  // marks the connections with input, accepts new clients
  TimeUs next = kNever;
  const TimeUs now = io::monotonic_now();
  for (std::size_t i = 0; i < connections_.size();) {
    Connection& c = *connections_[i];
    std::uint64_t timeout = UINT64_MAX;
    if (sd_bus_get_timeout(c.bus, &timeout) < 0) timeout = 0;
    if (c.ready || TimeUs(timeout) <= now) {
      c.ready = false;
      last_served_ = now;
      int r = 0;
      int n = 0;
      while (n < kMessagesPerPass && (r = sd_bus_process(c.bus, nullptr)) > 0) ++n;
      if (r < 0 || !sd_bus_is_open(c.bus)) {
        if (!c.peer) spdlog::warn("control: lost the D-Bus connection: {}", std::strerror(r < 0 ? -r : ECONNRESET));
        drop(c);  // erases connections_[i]
        continue;
      }
      if (n == kMessagesPerPass) {  // more queued: come back after the nodes ran
        c.ready = true;
        next = 0;
      }
      if (sd_bus_get_timeout(c.bus, &timeout) < 0) timeout = 0;
    }
    rearm(c);  // signals sent between passes may have left output queued
    if (timeout != UINT64_MAX) next = std::min(next, TimeUs(timeout));
    ++i;
  }
  return next;
}

void ControlEndpoints::before_sleep(TimeUs next_pass) {
  const TimeUs now = io::monotonic_now();
  loop_.allow_deferred_wakeup(next_pass == kNever || next_pass - now > kCallWaitUs ||
                              now - last_served_ >= kCallWaitUs);
}

}  // namespace cansim::control
