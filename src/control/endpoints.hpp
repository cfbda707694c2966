// Where the control API listens, on the daemon's one epoll loop (no thread):
// the private peer-to-peer D-Bus socket (as systemd's /run/systemd/private)
// and the system or user bus, in the loop's deferred set. After every loop
// pass the owner calls process(), and before_sleep() before it waits: every
// connection is serviced (a connection served only when
// its fd was readable can stall during authentication), its epoll interest
// re-armed from sd_bus_get_events, and the earliest sd-bus timeout returned.
#pragma once

#include <systemd/sd-bus.h>

#include <memory>
#include <string>
#include <vector>

#include "config/limits.hpp"
#include "control/message_gate.hpp"
#include "control/service.hpp"
#include "io/event_loop.hpp"

namespace cansim::control {

enum class BusChoice { kAuto, kSystem, kUser, kNone };

// The private socket's default path: $RUNTIME_DIRECTORY/control under
// systemd, else $XDG_RUNTIME_DIR/cansimd/control, else /run/cansimd/control
// as root, else /tmp/cansimd-$UID/control.
std::string default_control_socket();

// Bounds (config/limits.hpp, docs/limits.md): at most `max_clients` peer
// connections are served, and one uid other than root holds at most
// max_clients - max_clients / limits::kOtherUsersShare of them (the rest is
// kept for other users and root); one more gets org.freedesktop.DBus.Error.
// LimitsExceeded saying why to its first call, and is closed. A connection
// that has not finished the D-Bus handshake within limits::kAuthTimeoutUs,
// has made no method call within limits::kFirstCallTimeoutUs, or lets more
// than limits::kQueuedMessages answers and signals pile up unread, is
// dropped with a journal line. A peer's messages reach sd-bus through a
// MessageGate: one over limits::kMessageBytes is answered TooLarge unread.
// Warnings about clients are rate-limited.
class ControlEndpoints {
 public:
  // `first_call_us`: limits::kFirstCallTimeoutUs (tests shorten it).
  ControlEndpoints(io::EventLoop& loop, ControlService& service, std::size_t max_clients = limits::kDefaultMaxClients,
                   TimeUs first_call_us = limits::kFirstCallTimeoutUs);
  ~ControlEndpoints();

  // Listens on a fresh socket at `path` (a stale one is replaced): mode
  // 0660, group `cansim` when it exists. Throws std::runtime_error.
  void listen(const std::string& path);
  // Connects to the chosen bus and takes the name io.cansim.Cansimd1.
  // kAuto: the system bus when root and it is there, else the user bus when
  // it is there, else none. Returns a description ("system bus", ...) or ""
  // when no bus is used; throws std::runtime_error when an explicitly chosen
  // bus cannot be used.
  std::string connect_bus(BusChoice choice);

  // Services every connection (at most a bounded number of messages each,
  // and all of them within a bounded time, round robin: neither a flooding
  // client nor a stream of costly calls starves the nodes). Returns the
  // earliest time (CLOCK_MONOTONIC µs) at which process() must run again
  // (0: at once, after the nodes ran), or kNever.
  TimeUs process();
  // Before the loop sleeps until `next_pass` (CLOCK_MONOTONIC µs, kNever:
  // no deadline). A call wakes the loop unless the loop served calls within
  // the last 5 ms and its next pass is at most 5 ms away: then that pass
  // serves it. A call thus waits at most 5 ms, and a stream of calls costs
  // at most 200 extra wake-ups a second.
  void before_sleep(TimeUs next_pass);
  std::size_t connections() const { return connections_.size(); }
  const std::string& socket_path() const { return socket_path_; }

 private:
  struct Connection;
  struct Listener;
  struct Throttle;
  void accept_clients();
  Connection* serve_fd(int fd, uid_t uid, bool refusing);
  Connection* add_connection(sd_bus* bus, int fd, std::unique_ptr<MessageGate> gate, uid_t uid, bool refusing);
  void note_oversized(Connection& c, TimeUs now);
  void refuse(int fd, std::string why);
  // Why `c` must go (nullptr when it may stay), and which warning says so (nullptr: none).
  const char* must_go(const Connection& c, TimeUs now, Throttle** warning) const;
  void drop(Connection& c);
  void rearm(Connection& c);

  io::EventLoop& loop_;
  ControlService& service_;
  std::size_t max_clients_;
  std::size_t per_uid_;  // slots one uid other than root may hold
  TimeUs first_call_us_;
  std::string refusal_;  // what a client refused for want of a slot is told
  // One per kind of warning, each at most one line per limits::kWarningPeriodUs.
  std::unique_ptr<Throttle> warn_refused_, warn_slow_, warn_handshake_, warn_idle_, warn_large_, warn_failed_;
  std::unique_ptr<Listener> listener_;
  std::vector<std::unique_ptr<Connection>> connections_;
  std::string socket_path_;
  std::uint64_t next_id_ = 1;
  TimeUs last_served_ = 0;  // last pass that read a connection
  TimeUs pass_end_ = 0;     // the current pass serves connections until then
};

}  // namespace cansim::control
