// The private socket's message gate (control/message_gate.hpp): the D-Bus
// framing as a byte stream, and the endpoints answering a message over
// limits::kMessageBytes TooLarge without sd-bus ever reading it.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "config/limits.hpp"
#include "control/endpoints.hpp"
#include "control/message_gate.hpp"
#include "control/names.hpp"
#include "io/event_loop.hpp"
#include "support/captured_log.hpp"
#include "support/control_fleet.hpp"

namespace cansim::control {
namespace {

using Bytes = std::vector<std::uint8_t>;

const std::string kAuth = std::string(1, '\0') + "AUTH EXTERNAL 30\r\nNEGOTIATE_UNIX_FD\r\nBEGIN\r\n";

// A little-endian message's bytes: fixed header, `fields` bytes of header
// fields (any content: the framing reads only the lengths), `body` bytes.
Bytes message(std::uint32_t serial, std::uint32_t fields, std::uint32_t body, std::uint8_t fill = 0x5A) {
  Bytes m(16 + ((fields + 7) & ~7u) + body, fill);
  m[0] = 'l';
  m[1] = 1;
  m[2] = 0;
  m[3] = 1;
  for (int i = 0; i < 4; ++i) {
    m[4 + i] = std::uint8_t(body >> (8 * i));
    m[8 + i] = std::uint8_t(serial >> (8 * i));
    m[12 + i] = std::uint8_t(fields >> (8 * i));
  }
  return m;
}

Bytes stream(std::initializer_list<Bytes> messages) {
  Bytes out(kAuth.begin(), kAuth.end());
  for (const Bytes& m : messages) out.insert(out.end(), m.begin(), m.end());
  return out;
}

struct Fed {
  Bytes pass;
  std::size_t dropped = 0;
  int oversized = 0;
  std::uint64_t last = 0;
  const char* broken = nullptr;
};

// Feeds `in` in pieces of `piece` bytes.
Fed feed(const Bytes& in, std::size_t piece, std::size_t max = 1000) {
  MessageFraming framing(max);
  Fed f;
  for (std::size_t at = 0; at < in.size() && !f.broken; at += piece) {
    MessageFraming::Out out{&f.pass};
    framing.feed({in.data() + at, std::min(piece, in.size() - at)}, out);
    f.dropped += out.dropped;
    f.oversized += out.oversized;
    if (out.oversized) f.last = out.oversized_bytes;
    f.broken = out.broken;
  }
  return f;
}

TEST(MessageFraming, MessagesWithinTheBoundPassUnchangedInAnyPieces) {
  const Bytes in = stream({message(1, 100, 0), message(2, 13, 400), message(3, 0, 984 - 16)});
  for (std::size_t piece : {std::size_t(1), std::size_t(7), std::size_t(64), in.size()}) {
    const Fed f = feed(in, piece);
    EXPECT_EQ(f.pass, in) << "piece " << piece;
    EXPECT_EQ(f.oversized, 0);
    EXPECT_EQ(f.broken, nullptr);
  }
}

// Over the bound (1,000 here): never handed on; a stand-in with its serial
// and no body takes its place, and the next message passes again.
TEST(MessageFraming, AMessageOverTheBoundIsDroppedForAStandIn) {
  const Bytes big = message(0x1234, 40, 5000);
  const Bytes next = message(7, 24, 8);
  for (std::size_t piece : {std::size_t(1), std::size_t(333), std::size_t(100000)}) {
    const Fed f = feed(stream({big, next}), piece);
    const Bytes stand_in = too_large_stand_in(0x1234, 0);
    Bytes want(kAuth.begin(), kAuth.end());
    want.insert(want.end(), stand_in.begin(), stand_in.end());
    want.insert(want.end(), next.begin(), next.end());
    EXPECT_EQ(f.pass, want) << "piece " << piece;
    EXPECT_EQ(f.oversized, 1);
    EXPECT_EQ(f.last, big.size());
    EXPECT_EQ(f.dropped, big.size() - 16);
  }
}

// The stand-in is a method call sd-bus parses: io.cansim.Gate1.MessageTooLarge
// on the root path, the original serial, an 8-aligned end.
TEST(MessageFraming, TheStandInIsAWellFormedCall) {
  const Bytes m = too_large_stand_in(99, 0x1 | 0x4);
  ASSERT_EQ(m.size() % 8, 0u);
  EXPECT_EQ(m[0], 'l');
  EXPECT_EQ(m[1], 1);    // method call
  EXPECT_EQ(m[2], 0x1);  // NO_REPLY_EXPECTED kept, the rest dropped
  EXPECT_EQ(m[8], 99);
  // What sd-bus makes of the bytes, through a socketpair.
  sd_bus_message* parsed = nullptr;
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
  sd_bus* server = nullptr;
  sd_bus_new(&server);
  sd_bus_set_fd(server, sv[0], sv[0]);
  sd_id128_t id;
  sd_id128_randomize(&id);
  sd_bus_set_server(server, 1, id);
  sd_bus_set_anonymous(server, 1);
  ASSERT_GE(sd_bus_start(server), 0);
  const std::string auth = std::string(1, '\0') + "AUTH ANONYMOUS\r\nBEGIN\r\n";
  ASSERT_EQ(::write(sv[1], auth.data(), auth.size()), ssize_t(auth.size()));
  ASSERT_EQ(::write(sv[1], m.data(), m.size()), ssize_t(m.size()));
  for (int i = 0; i < 100 && !parsed; ++i) {
    sd_bus_process(server, &parsed);
    if (!parsed) sd_bus_wait(server, 10'000);
  }
  ASSERT_NE(parsed, nullptr);
  EXPECT_GT(sd_bus_message_is_method_call(parsed, kGateInterface, kGateTooLarge), 0);
  EXPECT_STREQ(sd_bus_message_get_path(parsed), kRootPath);
  std::uint64_t cookie = 0;
  sd_bus_message_get_cookie(parsed, &cookie);
  EXPECT_EQ(cookie, 99u);
  sd_bus_message_unref(parsed);
  sd_bus_close_unref(server);
  ::close(sv[1]);
}

TEST(MessageFraming, WhatIsNotDBusEndsTheConnection) {
  Bytes junk(kAuth.begin(), kAuth.end());
  junk.insert(junk.end(), 16, 'x');
  EXPECT_NE(feed(junk, 5).broken, nullptr);
  const Bytes endless(MessageFraming::kAuthBytes + 1, 'A');  // a handshake line without end
  EXPECT_NE(feed(endless, 4096).broken, nullptr);
}

// ---------------------------------------------------------------- endpoints

// 100 MiB AddNodes from a client: the answer is TooLarge, the connection
// goes on serving, and no loop pass read more than a slice of it (before,
// sd-bus read and checked it whole: 0.4 s here, 1.2 s in the VM).
TEST(GatedEndpoints, AHundredMebibyteCallIsAnsweredTooLargeUnread) {
  char tmpl[] = "/tmp/cansim-gate-XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  test::ControlFleet fleet{
      "interfaces: {vcan0: {}}\nnodes:\n  - {profile: generic-404, interface: vcan0, node_id: 1, name: g}\n"};
  io::EventLoop loop;
  ASSERT_TRUE(loop.open()) << loop.error();
  // A first-call limit of 250 ms, and a 300 ms pause of the server once the
  // oversized header is read, with most of the 100 MiB still to drain: the
  // oversized call counts as the client's call (on a loaded host the draining
  // outlasted the 10 s default and the connection was dropped). The client
  // builds its message before the server accepts it, so the limit cannot run
  // out while a loaded host fills 100 MiB.
  ControlEndpoints endpoints{loop, fleet.service(), 4, 250'000};
  const std::string path = dir + "/control";
  endpoints.listen(path);
  test::CapturedLog log;
  struct Result {
    std::atomic<bool> done{false};
    std::string error;
  };
  Result big, small;
  std::atomic<bool> built{false};
  std::thread client([&] {
    sd_bus* c = nullptr;
    sd_bus_new(&c);
    sd_bus_set_address(c, ("unix:path=" + path).c_str());
    sd_bus_start(c);
    const auto call = [&](sd_bus_message* m, Result& out) {
      sd_bus_error e = SD_BUS_ERROR_NULL;
      sd_bus_message* reply = nullptr;
      sd_bus_call(c, m, 0, &e, &reply);
      out.error = e.name ? std::string(e.name) + ": " + e.message : "";
      sd_bus_error_free(&e);
      sd_bus_message_unref(reply);
      sd_bus_message_unref(m);
      out.done = true;
    };
    const auto add_nodes = [&](const std::string& text) {
      sd_bus_message* m = nullptr;
      sd_bus_message_new_method_call(c, &m, nullptr, kRootPath, kFleetInterface, "AddNodes");
      sd_bus_message_append(m, "s", text.c_str());
      return m;
    };
    sd_bus_message* huge = add_nodes(std::string(100u << 20, 'x'));
    built = true;
    call(huge, big);
    call(add_nodes("["), small);  // the connection still serves
    sd_bus_close_unref(c);
  });
  while (!built) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const char* const answered = "bytes (at most 1048576): answered TooLarge, unread";
  bool waited = false;
  for (int i = 0; i < 200'000 && !small.done; ++i) {
    bool timer = false;
    int signal = 0;
    endpoints.before_sleep(kNever);
    loop.wait(10, timer, signal);
    endpoints.process();
    if (!waited && log.count(answered) == 1) {  // the rest of the 100 MiB still to drain
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      waited = true;
    }
  }
  client.join();
  std::filesystem::remove_all(dir);
  EXPECT_EQ(big.error.rfind("io.cansim.Error.TooLarge: a message of 10485", 0), 0u) << big.error;
  EXPECT_NE(big.error.find(" bytes; cansimd reads at most 1048576 from a client (docs/limits.md)"), std::string::npos)
      << big.error;
  EXPECT_EQ(small.error.rfind("io.cansim.Error.", 0), 0u) << small.error;
  EXPECT_EQ(small.error.find("TooLarge"), std::string::npos) << small.error;
  EXPECT_TRUE(waited);
  EXPECT_EQ(log.count(answered), 1u) << log.text.str();
}

}  // namespace
}  // namespace cansim::control
