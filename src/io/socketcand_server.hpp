// A bus without the kernel: cansimd serves one of its buses over TCP in the
// socketcand protocol (io/socketcand.hpp; docs/socketcand.md), and is its
// wire. Every connected client is a participant of the bus: what it sends
// (`< send >`) goes to LoopCore::submit as its frame, so on a timed bus it
// waits and arbitrates with the nodes' frames; every frame on the wire, the
// nodes' and the other clients', reaches each client in RAW mode as `< frame
// ... >` (not echoed to its sender, as CAN_RAW without RECV_OWN_MSGS).
//
// Decisions:
// - All on the daemon's one epoll loop: non-blocking sockets, no thread.
//   Frames reach the clients' output buffers as they go on the wire and are
//   written at the owner's flush() after each loop pass (one send() per
//   client per pass).
// - Bounded (the owner passes config/limits.hpp's figures): clients at once
//   (one more is told why in an `< error >` and closed), bytes a client
//   leaves unread (its kernel send buffer, then `max_unread` here: beyond, it
//   is dropped with a journal line and never blocks the loop), bytes read
//   from a client per loop pass, and frames of one client waiting for the
//   wire (beyond, its socket is not read: TCP holds the client back, as a CAN
//   controller's full transmit buffer would).
// - After `< ok >` to `< rawmode >` the bus's frames wait until the client
//   sends again or `rawmode_hold` passes: python-can reads that answer alone
//   and fails the handshake when a frame follows it in the same read.
// - Frames carry the wall clock (CLOCK_REALTIME) of the moment they leave
//   the wire, as SocketCAN's receive timestamps.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "io/event_loop.hpp"
#include "io/loop_core.hpp"
#include "io/socketcand.hpp"
#include "io/transport.hpp"

namespace cansim::io {

struct SocketcandSettings {
  std::string bus;                 // the name clients open (`< open bus >`)
  std::string host = "127.0.0.1";  // a numeric IPv4 or IPv6 address
  std::uint16_t port = 0;          // 0: a free port (port() says which)
  // Bounds (config/limits.hpp).
  std::size_t max_clients = 0;
  std::size_t max_unread = 0;     // bytes beyond the kernel's send buffer
  std::size_t send_buffer = 0;    // SO_SNDBUF of each client socket
  std::size_t read_per_pass = 0;  // bytes read from one client per loop pass
  std::size_t max_in_flight = 0;  // frames of one client queued on a timed bus
  TimeUs rawmode_hold = 0;
  TimeUs warning_period = 0;  // at most one journal line per kind of warning per period
};

struct SocketcandStats {
  std::uint64_t frames_in = 0;       // frames clients sent to the bus
  std::uint64_t frames_out = 0;      // the other frames on the wire: the nodes', a replay's
  std::uint64_t frames_lost = 0;     // clients' frames the full bus queue dropped
  std::uint64_t clients_served = 0;  // connections accepted
  std::uint64_t clients_refused = 0;
  std::uint64_t clients_dropped = 0;  // dropped for reading too slowly
  std::uint64_t errors_sent = 0;      // `< error >` answers to malformed messages
  std::uint64_t errors_out = 0;       // error frames for the master (`< error CLASS ... >`, fault error_frames)
};

class SocketcandServer : public Transport {
 public:
  enum class Level { kDebug, kInfo, kWarn };
  using Log = std::function<void(Level, const std::string&)>;
  using Clock = std::function<TimeUs()>;  // the core's time
  using WallClock = socketcand::Stamp (*)();

  SocketcandServer(EventLoop& loop, SocketcandSettings settings);
  ~SocketcandServer() override;
  SocketcandServer(const SocketcandServer&) = delete;
  SocketcandServer& operator=(const SocketcandServer&) = delete;

  // The loop core and bus the clients' frames go to, the core's clock, and
  // where the journal lines go. Before listen().
  void attach(LoopCore& core, BusId bus, Clock now, Log log = {});
  void set_wall_clock(WallClock clock) { wall_clock_ = clock; }
  // Binds and listens; false with error() ("127.0.0.1:29536: Address
  // already in use", io/failure.hpp).
  bool listen();
  const std::string& error() const { return error_; }
  void close();
  bool listening() const { return listen_fd_ >= 0; }
  const std::string& host() const { return settings_.host; }
  std::uint16_t port() const { return port_; }  // the bound port (after listen)
  const std::string& bus_name() const { return settings_.bus; }
  std::size_t clients() const;
  const SocketcandStats& stats() const { return stats_; }

  // Transport: a frame on the wire goes to every client in RAW mode (but its sender).
  void transmit(const CanFrame& frame) override { transmit_from(frame, 0); }
  // While no client is connected nobody sees the bus's frames: a timed bus
  // hands them over ahead (LoopCore::update_pacer, asked again as clients
  // come and go). A connected client, whatever its mode, has the loop pace
  // each frame: its own frames are counted back to it (max_in_flight) when
  // they end, and it sees those that end once it is in RAW mode.
  bool carries() const override;
  void transmit_from(const CanFrame& frame, Participant from) override;
  // An error the master's controller would report: `< error CLASS ... >`
  // to every client in RAW mode.
  void error(BusError e) override;

  // Writes what waits for the clients (after each loop pass), drops those
  // that read too slowly and ends the rawmode holds that are due.
  void flush();
  // The next hold that ends (core time), or kNever.
  TimeUs next_deadline() const;

 private:
  struct Client;
  struct Listener;
  struct Throttle;
  // Hands `text` (a buffer `format` writes the first time a client takes it) to
  // every client in RAW mode but `from`; true when `from` is a client.
  template <typename Format>
  bool deliver(Format&& format, char* text, Participant from);
  void accept_clients();
  void refuse(int fd, const std::string& peer);
  void on_client(Client& c, std::uint32_t events);
  void read_client(Client& c);
  void write_client(Client& c, TimeUs now);
  void update_interest(Client& c);
  void drop(Client& c, const std::string& why);
  void reap();
  void update_pacer();
  void log(Level level, const std::string& line) const;
  Participant next_participant();

  EventLoop& loop_;
  SocketcandSettings settings_;
  LoopCore* core_ = nullptr;
  BusId bus_ = 0;
  Clock now_;
  Log log_;
  WallClock wall_clock_;
  int listen_fd_ = -1;
  std::uint16_t port_ = 0;
  std::unique_ptr<Listener> listener_;
  std::vector<std::unique_ptr<Client>> clients_;
  std::unique_ptr<Throttle> warn_refused_, warn_slow_;
  Participant last_participant_ = 0;
  bool reap_pending_ = false;
  std::string error_;
  SocketcandStats stats_;
};

}  // namespace cansim::io
