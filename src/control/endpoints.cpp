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
constexpr int kMessagesPerPass = 32;  // per connection and loop pass
constexpr int kAcceptsPerPass = 64;
// A pass serves connections (and accepts new ones) for at most this long,
// then the nodes run: a client whose calls are cheap gets many per pass, one
// whose calls are costly (AddNodes loads a profile) one per pass.
constexpr TimeUs kPassBudgetUs = 2'000;
// Of which accepting new connections takes at most this much: a connect
// flood (64 threads reconnecting as fast as they are closed) took every pass
// and starved the connections already there, a handshake until its time ran out.
constexpr TimeUs kAcceptBudgetUs = kPassBudgetUs / 4;
// Refused clients of one uid waiting for their answer at once; more are
// closed at once (a flood of one user's does not take every refusal's place).
constexpr std::size_t kRefusingPerUid = 2;
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

// The socket's peer's uid; -1 when unknown.
uid_t peer_uid(int fd) {
  ucred cred{};
  socklen_t len = sizeof cred;
  return ::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0 ? cred.uid : uid_t(-1);
}

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
  bool ready = true;      // epoll reported the fd (or it is new): process() reads it
  TimeUs since = 0;       // accepted (CLOCK_MONOTONIC µs)
  uid_t uid = uid_t(-1);  // the peer's (SO_PEERCRED)
  bool called = false;    // it has made a method call
  bool refusing = false;  // over --max-clients: answers why, then goes
  bool answered = false;  // refusing: the first call has its answer
  std::string refusal;
  std::unique_ptr<MessageGate> gate;  // a peer's input (nullptr on a bus)
  std::uint64_t oversized_seen = 0;   // the gate's oversized messages already logged
  void on_events(std::uint32_t) override { ready = true; }
};

struct ControlEndpoints::Listener : io::FdHandler {
  explicit Listener(ControlEndpoints& e) : owner(e) {}
  void on_events(std::uint32_t) override { owner.accept_clients(); }
  ControlEndpoints& owner;
  int fd = -1;
};

ControlEndpoints::ControlEndpoints(io::EventLoop& loop, ControlService& service, std::size_t max_clients,
                                   TimeUs first_call_us)
    : loop_(loop),
      service_(service),
      max_clients_(max_clients),
      per_uid_(max_clients - max_clients / limits::kOtherUsersShare),
      first_call_us_(first_call_us),
      refusal_("cansimd serves at most " + std::to_string(max_clients) +
               " control clients at once (cansimd --max-clients); try again when one has disconnected"),
      warn_refused_(std::make_unique<Throttle>()),
      warn_slow_(std::make_unique<Throttle>()),
      warn_handshake_(std::make_unique<Throttle>()),
      warn_idle_(std::make_unique<Throttle>()),
      warn_large_(std::make_unique<Throttle>()),
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
  struct stat st {};
  if (const group* g = ::getgrnam("cansim"); g && (::stat(path.c_str(), &st) != 0 || st.st_gid != g->gr_gid)) {
    if (::chown(path.c_str(), uid_t(-1), g->gr_gid) < 0)
      spdlog::warn("{}: cannot give the control socket to group cansim: {}", path, std::strerror(errno));
  }
  listener_ = std::make_unique<Listener>(*this);
  listener_->fd = fd;
  if (!loop_.add_deferred(fd, EPOLLIN, listener_.get())) {
    ::close(fd);
    listener_.reset();
    throw std::runtime_error(path + ": " + loop_.error());
  }
  socket_path_ = path;
}

// A bounded number per pass: a connect flood must not hold the loop (the
// rest wait in the listen backlog for the next passes).
void ControlEndpoints::accept_clients() {
  const TimeUs until = std::min(pass_end_, io::monotonic_now() + kAcceptBudgetUs);
  for (int accepted = 0; accepted < kAcceptsPerPass && io::monotonic_now() < until; ++accepted) {
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
    const uid_t uid = peer_uid(fd);
    std::size_t peers = 0, mine = 0;
    for (const auto& c : connections_) {
      if (!c->peer || c->refusing) continue;
      ++peers;
      mine += c->uid == uid;
    }
    if (peers >= max_clients_) {
      warn_refused_->warn(io::monotonic_now(), "control socket: " + std::to_string(peers) +
                                                   " clients connected already (--max-clients " +
                                                   std::to_string(max_clients_) + "): refusing another");
      refuse(fd, refusal_);
      continue;
    }
    if (uid != 0 && mine >= per_uid_) {
      const std::string share = "uid " + std::to_string(uid) + " holds " + std::to_string(mine) + " of the " +
                                std::to_string(max_clients_) + " control client slots, all one user may (the other " +
                                std::to_string(max_clients_ - per_uid_) + " are kept for other users and root)";
      warn_refused_->warn(io::monotonic_now(), "control socket: " + share + ": refusing another");
      refuse(fd, "cansimd: " + share + "; try again when one of them has disconnected");
      continue;
    }
    serve_fd(fd, uid, false);
  }
}

// A peer-to-peer server connection on an accepted socket, its input read
// through a MessageGate; nullptr (the socket closed) when it cannot be set
// up. sd-bus reads a pipe, not the socket, so it cannot see the peer's
// credentials: the peer was identified by its socket (SO_PEERCRED, `uid`)
// when it was accepted, and sd-bus takes its handshake as said.
ControlEndpoints::Connection* ControlEndpoints::serve_fd(int fd, uid_t uid, bool refusing) {
  auto gate = std::make_unique<MessageGate>(fd, limits::kMessageBytes);
  sd_bus* bus = nullptr;
  bool owned = false;  // sd-bus closes the socket
  sd_id128_t id;
  sd_id128_randomize(&id);
  int r = gate->valid() ? sd_bus_new(&bus) : -EMFILE;
  if (r >= 0) r = sd_bus_set_fd(bus, gate->input_fd(), fd);
  if (r >= 0) {
    owned = true;
    gate->input_taken();
    r = sd_bus_set_server(bus, 1, id);
  }
  if (r >= 0) r = sd_bus_set_anonymous(bus, 1);
  if (r >= 0) r = sd_bus_negotiate_fds(bus, 0);
  if (r >= 0) r = sd_bus_start(bus);
  if (r >= 0) {
    // sd-bus asks for 8 MiB of kernel send buffer (and gets it as root):
    // what a client does not read stays within limits::kSocketBufferBytes.
    const int bytes = int(limits::kSocketBufferBytes);
    ::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &bytes, sizeof bytes);
    return add_connection(bus, fd, std::move(gate), uid, refusing);
  }
  const std::string line = std::string("control socket: cannot serve a client: ") + std::strerror(-r);
  if (client_gone(-r)) spdlog::debug("{}", line);
  else warn_failed_->warn(io::monotonic_now(), line);
  if (bus) sd_bus_close_unref(bus);
  if (!owned) ::close(fd);
  return nullptr;
}

// One client too many: it is told why (its first call's answer) and closed;
// beyond limits::kRefusing such at once, it is closed at once.
void ControlEndpoints::refuse(int fd, std::string why) {
  const uid_t uid = peer_uid(fd);
  std::size_t refusing = 0, theirs = 0;
  for (const auto& c : connections_) {
    refusing += c->refusing;
    theirs += c->refusing && c->uid == uid;
  }
  if (refusing >= limits::kRefusing || theirs >= kRefusingPerUid) {
    ::close(fd);
    return;
  }
  if (Connection* c = serve_fd(fd, uid, true)) c->refusal = std::move(why);
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
  add_connection(bus, sd_bus_get_fd(bus), nullptr, uid_t(-1), false);
  return what;
}

ControlEndpoints::Connection* ControlEndpoints::add_connection(sd_bus* bus, int fd, std::unique_ptr<MessageGate> gate,
                                                               uid_t uid, bool refusing) {
  auto c = std::make_unique<Connection>();
  c->bus = bus;
  c->peer = gate != nullptr;
  c->fd = fd;
  c->uid = uid;
  c->gate = std::move(gate);
  c->since = io::monotonic_now();
  c->refusing = refusing;
  const bool peer = c->peer;
  int r = 0;
  if (!refusing) {
    r = service_.attach(bus, peer, peer ? std::optional<uid_t>(uid) : std::nullopt);
    // Sees every message first: a method call makes the connection a client.
    if (r >= 0 && peer)
      r = sd_bus_add_filter(
          bus, nullptr,
          [](sd_bus_message* m, void* userdata, sd_bus_error*) -> int {
            if (sd_bus_message_is_method_call(m, nullptr, nullptr) > 0)
              static_cast<Connection*>(userdata)->called = true;
            return 0;
          },
          c.get());
    if (r >= 0 && peer) r = answer_oversized(bus, *c->gate);
  } else {  // every call answered with why, nothing served
    r = sd_bus_add_filter(
        bus, nullptr,
        [](sd_bus_message* m, void* userdata, sd_bus_error*) -> int {
          auto& self = *static_cast<Connection*>(userdata);
          if (sd_bus_message_is_method_call(m, nullptr, nullptr) <= 0) return 0;
          self.answered = true;
          return sd_bus_reply_method_errorf(m, SD_BUS_ERROR_LIMITS_EXCEEDED, "%s", self.refusal.c_str());
        },
        c.get());
  }
  if (r < 0 || c->fd < 0) {
    spdlog::warn("control: cannot serve a connection: {}", std::strerror(r < 0 ? -r : EBADF));
    sd_bus_close_unref(bus);
    return nullptr;
  }
  if (!loop_.add_deferred(c->fd, 0, c.get())) {
    spdlog::warn("control: cannot serve a connection: {}", loop_.error());
    if (!refusing) service_.detach(bus);
    sd_bus_close_unref(bus);
    return nullptr;
  }
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
  if (!c.called && now - c.since >= first_call_us_) {
    *warning = warn_idle_.get();
    return "made no call in time (an idle connection holds a slot others may need)";
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

// The socket's interest: input when sd-bus wants some (through the gate,
// when it has room), output when sd-bus has some.
void ControlEndpoints::note_oversized(Connection& c, TimeUs now) {
  const std::uint64_t n = c.gate->oversized_count();
  if (n == c.oversized_seen) return;
  c.oversized_seen = n;
  // A call, answered TooLarge by its own filter (which runs before the one
  // that marks calls): else a client still sending its 100 MiB after 10 s
  // would be dropped as one that made no call.
  c.called = true;
  warn_large_->warn(now, "control: " + describe_client(c.fd) + " sent a message of " +
                             std::to_string(c.gate->last_oversized_bytes()) + " bytes (at most " +
                             std::to_string(limits::kMessageBytes) + "): answered TooLarge, unread");
}

void ControlEndpoints::rearm(Connection& c) {
  int events = sd_bus_get_events(c.bus);
  std::uint32_t mask = 0;
  if (events > 0) {
    if ((events & POLLIN) && (!c.gate || c.gate->wants_read())) mask |= EPOLLIN;
    if (events & POLLOUT) mask |= EPOLLOUT;
  }
  if (mask == c.mask) return;
  if (loop_.modify_deferred(c.fd, mask, &c)) c.mask = mask;
  else warn_failed_->warn(io::monotonic_now(), "control: " + loop_.error() + " (retried at the next pass)");
}

// Every connection is looked at after every pass, but read only when epoll
// reported its fd or sd-bus says it has work (timeout due, e.g. 0 for a
// message it already buffered): an idle connection costs no syscall.
TimeUs ControlEndpoints::process() {
  const TimeUs now = io::monotonic_now();
  pass_end_ = now + kPassBudgetUs;
  // Marks the connections with input, accepts new clients.
  if (loop_.poll_deferred() < 0) warn_failed_->warn(now, "control: " + loop_.error());
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
      // A peer's input comes through its gate, a slice at a time, each
      // followed by sd-bus reading it (and whatever it could read already).
      while (n < kMessagesPerPass && io::monotonic_now() < pass_end_) {
        const bool moved = c.gate && c.gate->pump() != MessageGate::Pump::kNothing;
        if ((r = sd_bus_process(c.bus, nullptr)) < 0 || (r == 0 && !moved)) break;
        ++n;
      }
      if (c.gate) note_oversized(c, now);
      if (r < 0 || !sd_bus_is_open(c.bus)) {
        if (!c.peer) spdlog::warn("control: lost the D-Bus connection: {}", std::strerror(r < 0 ? -r : ECONNRESET));
        else if (c.gate->why())
          warn_failed_->warn(now, "control: " + describe_client(c.fd) + " dropped: " + c.gate->why());
        drop(c);  // erases connections_[i]
        continue;
      }
      const bool held_back = c.gate && !c.gate->wants_read() && c.gate->why() == nullptr;
      if (n == kMessagesPerPass || held_back ||
          (r > 0 && io::monotonic_now() >= pass_end_)) {  // more: after the nodes ran
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
    else if (c.peer && !c.called) next = std::min(next, c.since + first_call_us_);
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
  if (!loop_.allow_deferred_wakeup(next_pass == kNever || next_pass - now > kCallWaitUs ||
                                   now - last_served_ >= kCallWaitUs))
    warn_failed_->warn(now, "control: " + loop_.error());
}

}  // namespace cansim::control
