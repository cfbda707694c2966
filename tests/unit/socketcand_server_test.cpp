// The socketcand server on real loopback sockets and the daemon's kind of
// loop (io::EventLoop), with the loop core on a clock the test sets: two
// clients see each other's frames (never their own), a node answers a
// client's SDO request, the rawmode hold, the bounds (clients, a client that
// does not read), malformed messages answered, the pacer a timed bus uses
// with and without a client in RAW mode.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cerrno>
#include <chrono>

#include "config/limits.hpp"
#include "io/socketcand_server.hpp"
#include "support/sim.hpp"

namespace cansim::io {
namespace {

using socketcand::record;

using test::F;

socketcand::Stamp fixed_stamp() { return {1700000000, 123456}; }

// A blocking TCP client with a receive timeout.
class Client {
 public:
  explicit Client(std::uint16_t port, int rcvbuf = 0) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (rcvbuf) ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a), 0) << std::strerror(errno);
  }
  ~Client() { ::close(fd_); }
  void send(const std::string& s) { ASSERT_EQ(::send(fd_, s.data(), s.size(), MSG_NOSIGNAL), ssize_t(s.size())); }
  // What arrived within `ms` (empty when nothing; "EOF" appended at the end of the stream).
  std::string read(int ms) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, ms) <= 0) return {};
    char buf[4096];
    const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
    return n > 0 ? std::string(buf, std::size_t(n)) : n == 0 ? "EOF" : "";
  }
  int fd() const { return fd_; }

 private:
  int fd_ = -1;
};

class SocketcandServerTest : public ::testing::Test {
 protected:
  SocketcandServerTest() : profile(test::load_repo_profile("generic-404")) {}

  void start(SocketcandSettings s = {}) {
    ASSERT_TRUE(loop.open()) << loop.error();
    s.bus = "bench";
    s.host = "127.0.0.1";
    if (!s.max_clients) s.max_clients = limits::kSocketcandClients;
    if (!s.max_unread) s.max_unread = limits::kSocketcandUnread;
    if (!s.read_per_pass) s.read_per_pass = limits::kSocketcandReadPerPass;
    if (!s.max_in_flight) s.max_in_flight = limits::kSocketcandInFlight;
    if (!s.rawmode_hold) s.rawmode_hold = limits::kSocketcandRawmodeHoldUs;
    s.warning_period = limits::kWarningPeriodUs;
    server = std::make_unique<SocketcandServer>(loop, s);
    bus = core.add_bus("bench", *server, 3);
    server->attach(
        core, bus, [this] { return now; },
        [this](SocketcandServer::Level level, const std::string& line) {
          if (level == SocketcandServer::Level::kWarn) logged.push_back(line);
        });
    server->set_wall_clock(fixed_stamp);
    ASSERT_TRUE(server->listen()) << server->error();
  }
  // One pass of the daemon's loop: events, the core, the flush.
  void pass(int timeout_ms = 20) {
    bool timer = false;
    int signal = 0;
    loop.wait(timeout_ms, timer, signal);
    core.run_due(now);
    server->flush();
  }
  // Passes until `c` has read something containing `what` (at most ~2 s).
  std::string until(Client& c, const std::string& what) {
    std::string got;
    for (int i = 0; i < 100 && got.find(what) == std::string::npos; ++i) {
      pass(5);
      got += c.read(15);
    }
    return got;
  }
  // A 4 KiB bound in cansimd, 64 KiB in the client's socket.
  void start_with_room_in_the_socket() {
    SocketcandSettings s;
    s.send_buffer = 64 * 1024;
    s.max_unread = 4096;
    start(s);
  }
  // Passes until `c` has read `n` frame records (at most ~2 s).
  std::string records(Client& c, std::size_t n) {
    std::string got;
    for (int i = 0; i < 100 && got.size() < n * socketcand::kRecord; ++i) {
      pass(0);
      got += c.read(20);
    }
    return got;
  }
  void handshake(Client& c, bool send_after = true) {
    ASSERT_EQ(until(c, "< hi >"), "< hi >");
    c.send("< open bench >");
    ASSERT_EQ(until(c, "< ok >"), "< ok >");
    c.send("< rawmode >");
    ASSERT_EQ(until(c, "< ok >"), "< ok >");
    if (send_after) {
      c.send("< echo >");  // ends the hold
      ASSERT_EQ(until(c, "< echo >"), record("< echo >"));
    }
  }

  config::Profile profile;
  EventLoop loop;
  LoopCore core;
  TimeUs now = ms(10);
  std::unique_ptr<SocketcandServer> server;
  BusId bus = 0;
  std::vector<std::string> logged;
};

TEST_F(SocketcandServerTest, TwoClientsSeeEachOthersFramesButNotTheirOwn) {
  start();
  ASSERT_NE(server->port(), 0);
  Client a(server->port()), b(server->port());
  handshake(a);
  handshake(b);
  EXPECT_EQ(server->clients(), 2u);
  a.send("< send 123 2 1 ab >");
  EXPECT_EQ(until(b, ">"), record("< frame 123 1700000000.123456 01AB >"));
  b.send("< send 1ABCDEF0 0 >");
  EXPECT_EQ(until(a, ">"), record("< frame 1ABCDEF0 1700000000.123456  >"));
  pass();
  EXPECT_EQ(a.read(50), "");  // nothing of its own came back
  EXPECT_EQ(b.read(50), "");
  EXPECT_EQ(server->stats().frames_in, 2u);
  EXPECT_EQ(server->stats().frames_out, 0u);  // no node's frame
}

TEST_F(SocketcandServerTest, ANodeAnswersAClientOnATimedBus) {
  start();
  core.set_bus_model(bus, BusModel::kTimed);
  core.power_on(core.add_node(bus, config::node_setup(profile, 5)), now);
  Client master(server->port());
  handshake(master);
  now = ms(100);
  core.run_until(now);
  EXPECT_EQ(until(master, ">"), record("< frame 705 1700000000.123456 00 >"));  // the boot-up, once on the wire
  master.send("< send 605 8 40 0 10 0 0 0 0 0 >");
  // Nothing before the request ends on the wire (124 bits at 250 kbit/s),
  // then the node's answer (119 bits) ends.
  for (int i = 0; i < 5; ++i) pass(5);
  EXPECT_EQ(master.read(20), "");
  EXPECT_EQ(core.bus_load(bus).queued, 1u);
  now += (124 + 119) * 4;
  core.run_until(now);
  EXPECT_EQ(until(master, ">"), record("< frame 585 1700000000.123456 4300100094010200 >"));
}

TEST_F(SocketcandServerTest, WithoutAClientATimedBusIsHandedOverAhead) {
  // Nobody sees the frames: a burst is handed over ahead (one wake-up a
  // batch). A client connects: the loop paces each frame again, and what
  // was handed over and ends later is written at its end; gone: ahead again.
  start();
  core.set_bus_model(bus, BusModel::kTimed);
  EXPECT_EQ(core.bus_pacer(bus), Pacer::kAhead);
  {
    Client master(server->port());
    ASSERT_EQ(until(master, "< hi >"), "< hi >");
    EXPECT_EQ(core.bus_pacer(bus), Pacer::kLoop);
  }
  for (int i = 0; i < 200 && server->clients() > 0; ++i) pass(5);  // the EOF seen (at most ~1 s)
  EXPECT_EQ(server->clients(), 0u);
  EXPECT_EQ(core.bus_pacer(bus), Pacer::kAhead);
}

TEST_F(SocketcandServerTest, AClientThatSendsWithoutRawModeIsReadOnAsItsFramesEnd) {
  // A client's frames waiting for the bus are bounded (max_in_flight): each
  // counts back to it when it ends on the wire, whether or not a client
  // reads the bus (no client in RAW mode here).
  start();
  core.set_bus_model(bus, BusModel::kTimed);
  Client sender(server->port());
  ASSERT_EQ(until(sender, "< hi >"), "< hi >");
  sender.send("< open bench >");
  ASSERT_EQ(until(sender, "< ok >"), "< ok >");
  std::string sends;
  for (int i = 0; i < 120; ++i) sends += "< send 123 1 00 >";
  sender.send(sends);
  ASSERT_GT(120u, limits::kSocketcandInFlight);
  for (int i = 0; i < 400 && server->stats().frames_in < 120; ++i) {
    now += 1000;
    core.run_until(now);
    pass(1);
  }
  EXPECT_EQ(server->stats().frames_in, 120u);
  EXPECT_EQ(server->stats().frames_out, 0u);  // none of them counted as a node's
}

TEST_F(SocketcandServerTest, ErrorsForTheMasterAreSocketcandsErrorMessages) {
  // What the fault error_frames and a collision report: the error frame's
  // class bits (linux/can/error.h) as socketcand's state_raw.c writes them.
  start();
  Client c(server->port());
  handshake(c);
  server->error(BusError::kPassive);  // CAN_ERR_CRTL | CAN_ERR_CNT
  EXPECT_EQ(until(c, ">"), record("< error 204 1700000000.123456 >"));
  server->error(BusError::kStuff);  // CAN_ERR_PROT | CAN_ERR_BUSERROR
  EXPECT_EQ(until(c, ">"), record("< error 088 1700000000.123456 >"));
  server->error(BusError::kBusOff);  // CAN_ERR_BUSOFF | CAN_ERR_CNT
  EXPECT_EQ(until(c, ">"), record("< error 240 1700000000.123456 >"));
  EXPECT_EQ(server->stats().errors_out, 3u);
  EXPECT_EQ(server->stats().frames_out, 0u);
}

TEST_F(SocketcandServerTest, FramesWaitAfterRawmodeUntilTheClientSpeaksOrTheHoldEnds) {
  start();
  Client c(server->port());
  handshake(c, false);
  server->transmit(F(0x701, {0x05}));
  for (int i = 0; i < 5; ++i) pass(5);
  EXPECT_EQ(c.read(20), "");  // python-can still reads `< ok >` alone
  EXPECT_EQ(server->next_deadline(), ms(10) + limits::kSocketcandRawmodeHoldUs);
  now = server->next_deadline();
  EXPECT_EQ(until(c, ">"), record("< frame 701 1700000000.123456 05 >"));
  EXPECT_EQ(server->next_deadline(), kNever);
}

TEST_F(SocketcandServerTest, MalformedMessagesAreAnswered) {
  start();
  Client c(server->port());
  handshake(c);
  c.send("< send 123 9 >< fdsend 1 0 >");
  EXPECT_EQ(until(c, "fdsend"),
            record("< error send: expected a DLC of 0 to 8 >") + record("< error unknown command fdsend >"));
  EXPECT_EQ(server->stats().errors_sent, 2u);
  EXPECT_EQ(server->stats().frames_in, 0u);
}

TEST_F(SocketcandServerTest, OneClientTooManyIsToldWhyAndClosed) {
  SocketcandSettings s;
  s.max_clients = 1;
  start(s);
  Client a(server->port());
  handshake(a);
  Client b(server->port());
  EXPECT_EQ(until(b, "EOF"), "< error cansimd serves at most 1 socketcand clients on bench at once >EOF");
  EXPECT_EQ(server->stats().clients_refused, 1u);
  ASSERT_EQ(logged.size(), 1u);
  EXPECT_NE(logged[0].find("refused: 1 clients are connected"), std::string::npos) << logged[0];
}

TEST_F(SocketcandServerTest, AClientThatDoesNotReadIsDroppedAndTheOthersGoOn) {
  SocketcandSettings s;
  s.send_buffer = 4096;
  s.max_unread = 8192;
  start(s);
  Client slow(server->port(), 4096), fast(server->port());
  handshake(slow);
  handshake(fast);
  std::string seen;
  for (int i = 0; i < 4000 && server->clients() == 2; ++i) {
    server->transmit(F(0x181, {std::uint8_t(i), 0, 0, 0, 0, 0, 0, 0}));
    if (i % 50 == 0) {
      pass(0);
      seen += fast.read(0);
    }
  }
  pass(0);
  EXPECT_EQ(server->clients(), 1u);
  EXPECT_EQ(server->stats().clients_dropped, 1u);
  ASSERT_FALSE(logged.empty());
  EXPECT_NE(logged.back().find("dropped: reads too slowly (8 KiB unread beyond its socket buffer)"), std::string::npos)
      << logged.back();
  server->transmit(F(0x182, {0x42}));
  EXPECT_NE(until(fast, "< frame 182"), "");
}

// A port in use: listen() says so (io/failure.hpp) and the server stays closed.
TEST_F(SocketcandServerTest, AListenThatFailsSaysWhy) {
  start();
  SocketcandSettings s;
  s.host = "127.0.0.1";
  s.port = server->port();
  SocketcandServer second(loop, s);
  second.attach(core, core.add_bus("second", second, 3), [this] { return now; });
  EXPECT_FALSE(second.listen());
  EXPECT_EQ(second.error(), "127.0.0.1:" + std::to_string(server->port()) + ": Address already in use");
  EXPECT_FALSE(second.listening());
}

// One loop pass can put more frames on the wire than the bound holds (a
// replay's frames of one instant on an ideal bus, a timed bus catching up
// after the host stalled): they go to the client's socket buffer first, so a
// client with room there is not dropped as one that "reads too slowly".
TEST_F(SocketcandServerTest, ABurstOfOnePassLargerThanTheBoundGoesToTheSocketFirst) {
  start_with_room_in_the_socket();
  Client c(server->port(), 64 * 1024);
  handshake(c);
  constexpr int kFrames = 200;  // 200 records: 12,800 bytes, three times the bound
  for (int i = 0; i < kFrames; ++i) server->transmit(F(0x123, {std::uint8_t(i)}));
  pass(0);
  EXPECT_EQ(server->stats().clients_dropped, 0u);
  EXPECT_EQ(server->clients(), 1u);
  EXPECT_TRUE(logged.empty()) << logged.front();
  const std::string got = records(c, kFrames);
  EXPECT_EQ(got.size(), kFrames * socketcand::kRecord);
  EXPECT_NE(got.find(record("< frame 123 1700000000.123456 C7 >")), std::string::npos);
}

// python-can reads nothing but `< ok >` until the rawmode hold ends: the
// frames held for it meanwhile are cansimd's doing, not a slow reader's. A
// bus carrying more than the bound in 200 ms (a 1 Mbit/s bus near full
// load) must not drop a client that just connected; the hold may use the
// share of its socket buffer, which is empty then.
TEST_F(SocketcandServerTest, FramesHeldDuringTheRawmodeHoldDoNotDropTheClient) {
  start_with_room_in_the_socket();
  Client c(server->port(), 64 * 1024);
  handshake(c, false);
  constexpr int kFrames = 200;  // 12,800 bytes held, three times the bound
  for (int i = 0; i < kFrames; ++i) {
    server->transmit(F(0x123, {std::uint8_t(i)}));
    if (i % 20 == 0) pass(0);
  }
  pass(0);
  EXPECT_EQ(server->stats().clients_dropped, 0u);
  EXPECT_EQ(c.read(20), "");  // still held
  now = server->next_deadline();
  EXPECT_EQ(records(c, kFrames).size(), kFrames * socketcand::kRecord);
}

}  // namespace
}  // namespace cansim::io
