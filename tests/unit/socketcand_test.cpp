// The socketcand protocol sans I/O (io/socketcand.hpp): frame text as
// socketcand and python-can 4.1 write and read it, `< send >` parsing, and
// the session's state machine byte by byte (handshake answers alone, a
// newline before every later message, `< error >` for what is malformed).
#include <gtest/gtest.h>

#include "io/socketcand.hpp"
#include "support/sim.hpp"

namespace cansim::io::socketcand {
namespace {

using test::F;

std::string text_of(const CanFrame& f, Stamp at) {
  char buf[kMaxFrameText];
  return std::string(buf, format_frame(f, at, buf));
}

TEST(SocketcandText, FramesAsSocketcandWritesThem) {
  EXPECT_EQ(text_of(F(0x185, {0x01, 0xAB}), {1700000000, 42}), record("< frame 185 1700000000.000042 01AB >"));
  // No data: two spaces before `>` (python-can splits the message on them).
  EXPECT_EQ(text_of(F(0x7, {}), {5, 999999}), record("< frame 007 5.999999  >"));
  CanFrame ext = F(0x1ABCDEF, {0xFF});
  ext.flags |= CanFrame::kExtended;
  EXPECT_EQ(text_of(ext, {0, 0}), record("< frame 01ABCDEF 0.000000 FF >"));
  EXPECT_EQ(text_of(CanFrame::remote(0x711, 1), {3, 7}), record("< rtr 711 3.000007 1 >"));
  CanFrame full = F(0x1FFFFFFF, {1, 2, 3, 4, 5, 6, 7, 8});
  full.flags |= CanFrame::kExtended;
  EXPECT_LE(text_of(full, {std::int64_t(1) << 62, 999999}).size(), kMaxFrameText);
}

TEST(SocketcandText, ErrorsAsSocketcandWritesThem) {
  char buf[kMaxFrameText];
  EXPECT_EQ(std::string(buf, format_error(0x088, {1700000000, 42}, buf)), record("< error 088 1700000000.000042 >"));
  EXPECT_EQ(std::string(buf, format_error(0x20000004, {5, 1}, buf)), record("< error 004 5.000001 >"));  // no flag
}

TEST(SocketcandText, SendAsPythonCanWritesIt) {
  CanFrame f;
  std::string why;
  // python-can 4.1: `< send {id:X} {dlc:X} {each byte %x} >`.
  ASSERT_TRUE(parse_send("601 8 40 0 10 0 0 0 0 0", false, f, why)) << why;
  EXPECT_EQ(f, F(0x601, {0x40, 0x00, 0x10, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(f.extended());
  ASSERT_TRUE(parse_send("0 2 1 0", false, f, why));  // NMT start all
  EXPECT_EQ(f, F(0x000, {0x01, 0x00}));
  ASSERT_TRUE(parse_send("701 0 ", false, f, why));  // python-can: `< send 701 0  >`
  EXPECT_EQ(f.dlc, 0);
  // 8 digits (socketcand's rule) or above 0x7FF: 29 bits.
  ASSERT_TRUE(parse_send("00000123 1 ff", false, f, why));
  EXPECT_TRUE(f.extended());
  EXPECT_EQ(f.id, 0x123u);
  ASSERT_TRUE(parse_send("18DAF110 0", false, f, why));
  EXPECT_TRUE(f.extended());
  ASSERT_TRUE(parse_send("800 0", false, f, why));
  EXPECT_TRUE(f.extended());
  ASSERT_TRUE(parse_send("711 1", true, f, why));
  EXPECT_TRUE(f.rtr());
  EXPECT_EQ(f.dlc, 1);
}

TEST(SocketcandText, MalformedSendsSayWhy) {
  CanFrame f;
  std::string why;
  const std::pair<const char*, const char*> cases[] = {
      {"", "send: expected an identifier of 1 to 8 hex digits, at most 1FFFFFFF"},
      {"12G 0", "send: expected an identifier of 1 to 8 hex digits, at most 1FFFFFFF"},
      {"20000000 0", "send: expected an identifier of 1 to 8 hex digits, at most 1FFFFFFF"},
      {"123456789 0", "send: expected an identifier of 1 to 8 hex digits, at most 1FFFFFFF"},
      {"123", "send: expected a DLC of 0 to 8"},
      {"123 9", "send: expected a DLC of 0 to 8"},
      {"123 10", "send: expected a DLC of 0 to 8"},
      {"123 2 1", "send: 1 data byte(s) for DLC 2"},
      {"123 1 1 2", "send: 2 data byte(s) for DLC 1"},
      {"123 1 100", "send: data byte 1 is not 1 or 2 hex digits"},
      {"123 2 1 zz", "send: data byte 2 is not 1 or 2 hex digits"},
      {"123 8 1 2 3 4 5 6 7 8 9", "send: more than 8 data bytes"},
  };
  for (auto [args, expected] : cases) {
    EXPECT_FALSE(parse_send(args, false, f, why)) << args;
    EXPECT_EQ(why, expected) << args;
  }
  EXPECT_FALSE(parse_send("711 1 00", true, f, why));
  EXPECT_EQ(why, "sendrtr: expected no data bytes");
}

struct Frames : Session::Sink {
  void frame(const CanFrame& f) override { got.push_back(f); }
  std::vector<CanFrame> got;
};

class SessionTest : public ::testing::Test {
 protected:
  // What the session answers to `in`, fed at once or byte by byte.
  std::string feed(std::string_view in, bool bytewise = false) {
    std::string out;
    if (!bytewise) session.feed(in, out, frames);
    for (std::size_t i = 0; bytewise && i < in.size(); ++i) session.feed(in.substr(i, 1), out, frames);
    return out;
  }
  void handshake() {
    ASSERT_EQ(feed("< open bench >"), "< ok >");
    ASSERT_EQ(feed("< rawmode >"), "< ok >");
  }
  Session session{"bench"};
  Frames frames;
};

TEST_F(SessionTest, TheHandshakeAnswersGoAloneThenEveryMessageStartsWithANewline) {
  EXPECT_EQ(Session::greeting(), "< hi >");
  EXPECT_EQ(session.mode(), Session::Mode::kNoBus);
  EXPECT_EQ(feed("< open bench >", true), "< ok >");
  EXPECT_EQ(session.mode(), Session::Mode::kBcm);
  EXPECT_FALSE(session.receives_frames());
  EXPECT_EQ(feed("< rawmode >"), "< ok >");
  EXPECT_TRUE(session.receives_frames());
  EXPECT_EQ(feed("< echo >"), record("< echo >"));
  EXPECT_EQ(feed("< rawmode >"), record("< ok >"));
  EXPECT_EQ(feed("< bcmmode >"), record("< ok >"));
  EXPECT_FALSE(session.receives_frames());
  EXPECT_EQ(session.errors(), 0u);
}

TEST_F(SessionTest, FramesGoToTheBusInBcmAndRawMode) {
  ASSERT_EQ(feed("< open bench >"), "< ok >");
  EXPECT_EQ(feed("< send 0 2 1 0 >"), "");
  EXPECT_EQ(feed("< rawmode >"), "< ok >");
  // Back to back, split anywhere, with or without separators, as python-can sends them.
  EXPECT_EQ(feed("< send 601 8 40 0 10 0 0 0 0 0 >< sendrtr 711 1 >\n  < send 123 0  >", true), "");
  EXPECT_EQ(frames.got, (std::vector<CanFrame>{F(0x000, {1, 0}), F(0x601, {0x40, 0, 0x10, 0, 0, 0, 0, 0}),
                                               CanFrame::remote(0x711, 1), F(0x123, {})}));
  EXPECT_EQ(session.messages(), 6u);
}

TEST_F(SessionTest, AnotherBusIsRefusedAndTheConnectionEnds) {
  EXPECT_EQ(feed("< open vcan0 >"), "< error could not open bus: this port serves bench >");
  EXPECT_TRUE(session.closed());
  EXPECT_EQ(feed("< open bench >"), "");  // nothing is taken after
}

TEST_F(SessionTest, MalformedMessagesAreAnsweredAndNothingElseChanges) {
  EXPECT_EQ(feed("< rawmode >"), "< error unknown command rawmode (expected open BUS) >");
  EXPECT_EQ(feed("< >"), "< error empty message >");
  EXPECT_EQ(feed("< open >"), "< error open: expected one bus name >");
  EXPECT_EQ(feed("< open bench extra >"), "< error open: expected one bus name >");
  handshake();
  EXPECT_EQ(feed("< send 123 9 >"), record("< error send: expected a DLC of 0 to 8 >"));
  EXPECT_EQ(feed("< subscribe 0 0 123 >"),
            record("< error subscribe: the broadcast manager's jobs are not served, use rawmode >"));
  EXPECT_EQ(feed("< isotpmode >"), record("< error isotpmode: not served (rawmode and bcmmode are) >"));
  EXPECT_EQ(feed("< open bench >"), record("< error open: bus bench is open already >"));
  EXPECT_EQ(feed("< echo now >"), record("< error echo: expected no arguments >"));
  EXPECT_EQ(feed("< fr\x01me >"), record("< error unknown command  >"));  // never quotes what is not a word
  EXPECT_EQ(feed("garbage< echo >junk"), record("< error text outside a message ignored >") + record("< echo >") +
                                             record("< error text outside a message ignored >"));
  EXPECT_EQ(feed("< send 1 0 < echo >"),
            record("< error message without its closing bracket ignored >") + record("< echo >"));
  EXPECT_EQ(feed("<" + std::string(200, 'x') + "> < echo >"),
            record("< error message longer than 128 bytes ignored >") + record("< echo >"));
  EXPECT_TRUE(frames.got.empty());
  EXPECT_TRUE(session.receives_frames());
  EXPECT_EQ(session.errors(), 14u);
}

TEST(SocketcandReader, ReadsWhatTheServerWrites) {
  MessageReader reader;
  const CanFrame a = F(0x185, {0x01, 0xAB});
  const CanFrame b = CanFrame::remote(0x711, 1);
  std::string stream = "< hi >< ok >" + text_of(a, {1700000000, 250000}) + text_of(b, {1700000001, 0}) + "\n< frame 12";
  reader.append(stream.substr(0, 20));
  reader.append(stream.substr(20));
  std::vector<std::string> bodies;
  for (std::string body; reader.next(body);) bodies.push_back(body);
  ASSERT_EQ(bodies.size(), 4u);
  EXPECT_EQ(bodies[0], " hi ");
  CanFrame f;
  double t = 0;
  EXPECT_FALSE(parse_frame_message(bodies[1], f, t));
  ASSERT_TRUE(parse_frame_message(bodies[2], f, t));
  EXPECT_EQ(f, a);
  EXPECT_DOUBLE_EQ(t, 1700000000.25);
  ASSERT_TRUE(parse_frame_message(bodies[3], f, t));
  EXPECT_EQ(f, b);
  // The protocol document's form, bytes apart, is read too.
  ASSERT_TRUE(parse_frame_message(" frame 123 23.424242 11 22 33 44 ", f, t));
  EXPECT_EQ(f, F(0x123, {0x11, 0x22, 0x33, 0x44}));
  EXPECT_FALSE(parse_frame_message(" frame 123 x 11 ", f, t));
  EXPECT_FALSE(parse_frame_message(" frame 123 1.0 1 ", f, t));
  reader.append("3 1.000000 AA >");
  std::string body;
  ASSERT_TRUE(reader.next(body));
  ASSERT_TRUE(parse_frame_message(body, f, t));
  EXPECT_EQ(f, F(0x123, {0xAA}));
}

}  // namespace
}  // namespace cansim::io::socketcand
