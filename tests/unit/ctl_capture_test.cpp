// cansimctl capture and replay sans I/O: candump -L lines written and read
// (the format canplayer and python-can's can.LogReader take), and the
// command lines of both verbs.
#include <gtest/gtest.h>

#include "ctl/args.hpp"
#include "ctl/candump.hpp"

namespace cansim::ctl {
namespace {

RawFrame raw(std::uint32_t id, std::vector<std::uint8_t> data, double t = 1700000000.123456) {
  RawFrame f;
  f.time = t;
  f.interface = "bench";
  f.id = id;
  f.dlc = std::uint8_t(data.size());
  for (std::size_t i = 0; i < data.size(); ++i) f.data[i] = data[i];
  return f;
}

TEST(Candump, LinesAsCandumpWritesThem) {
  EXPECT_EQ(candump_line(raw(0x185, {0x01, 0xAB})), "(1700000000.123456) bench 185#01AB\n");
  EXPECT_EQ(candump_line(raw(0x7, {}, 5.000001)), "(5.000001) bench 007#\n");
  RawFrame ext = raw(0x1ABCDEF, {0xFF});
  ext.extended = true;
  EXPECT_EQ(candump_line(ext), "(1700000000.123456) bench 01ABCDEF#FF\n");
  RawFrame rtr = raw(0x711, {});
  rtr.rtr = true;
  rtr.dlc = 1;
  EXPECT_EQ(candump_line(rtr), "(1700000000.123456) bench 711#R1\n");
  rtr.dlc = 0;
  EXPECT_EQ(candump_line(rtr), "(1700000000.123456) bench 711#R\n");
  RawFrame err = raw(0x004, {0, 4, 0, 0, 0, 0, 0, 0});
  err.error = true;
  EXPECT_EQ(candump_line(err), "(1700000000.123456) bench 20000004#0004000000000000\n");
}

TEST(Candump, LinesReadBack) {
  std::int64_t us = 0;
  RawFrame f;
  std::string why;
  ASSERT_TRUE(parse_candump_line("(1700000000.123456) vcan0 185#01AB\n", us, f, why)) << why;
  EXPECT_EQ(us, 1700000000123456);
  EXPECT_EQ(f.interface, "vcan0");
  EXPECT_EQ(f.id, 0x185u);
  EXPECT_FALSE(f.extended);
  ASSERT_EQ(f.dlc, 2);
  EXPECT_EQ(f.data[1], 0xAB);
  ASSERT_TRUE(parse_candump_line("(1.5) can0 01ABCDEF#", us, f, why)) << why;
  EXPECT_EQ(us, 1500000);
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.dlc, 0);
  ASSERT_TRUE(parse_candump_line("(2.000000) can0 711#R1 R", us, f, why)) << why;  // candump -x marks tolerated
  EXPECT_TRUE(f.rtr);
  EXPECT_EQ(f.dlc, 1);
  EXPECT_FALSE(parse_candump_line("", us, f, why));
  EXPECT_EQ(why, "");
  EXPECT_FALSE(parse_candump_line("# a comment", us, f, why));
  EXPECT_EQ(why, "");
  EXPECT_FALSE(parse_candump_line("(2.0) can0 20000004#0004000000000000", us, f, why));
  EXPECT_EQ(why, "not replayed: an error frame");
  EXPECT_FALSE(parse_candump_line("(2.0) can0 123##1112233", us, f, why));
  EXPECT_EQ(why, "not replayed: a CAN FD frame");
  const std::pair<const char*, const char*> bad[] = {
      {"185#01AB", "expected (SECONDS.MICROSECONDS) INTERFACE ID#DATA"},
      {"(x) can0 185#01", "expected (SECONDS.MICROSECONDS) INTERFACE ID#DATA"},
      {"(1.0) can0 18#01", "expected ID#DATA with an identifier of 3 or 8 hex digits"},
      {"(1.0) can0 185-01", "expected ID#DATA with an identifier of 3 or 8 hex digits"},
      {"(1.0) can0 800#01", "an 11-bit identifier above 7FF"},
      {"(1.0) can0 185#0", "expected 0 to 8 data bytes as pairs of hex digits"},
      {"(1.0) can0 185#001122334455667788", "expected 0 to 8 data bytes as pairs of hex digits"},
      {"(1.0) can0 185#zz", "expected 0 to 8 data bytes as pairs of hex digits"},
      {"(1.0) can0 185#R9", "expected R or R0..R8 for a remote frame"},
  };
  for (auto [line, expected] : bad) {
    EXPECT_FALSE(parse_candump_line(line, us, f, why)) << line;
    EXPECT_EQ(why, expected) << line;
  }
  // What capture writes, replay reads.
  RawFrame ext = raw(0x18DAF110, {1, 2, 3});
  ext.extended = true;
  ASSERT_TRUE(parse_candump_line(candump_line(ext), us, f, why));
  EXPECT_EQ(candump_line(f), candump_line(ext));
}

TEST(CaptureReplayArgs, Verbs) {
  Request r = parse_command_line({"capture", "bench", "out.log"}).request;
  EXPECT_EQ(r.output, Output::kCapture);
  EXPECT_EQ(r.interfaces, std::vector<std::string>{"bench"});
  EXPECT_EQ(r.file, "out.log");
  r = parse_command_line({"replay", "in.log", "--on", "vcan0"}).request;
  EXPECT_EQ(r.output, Output::kReplay);
  EXPECT_EQ(r.interfaces, std::vector<std::string>{"vcan0"});
  EXPECT_EQ(r.replay, ReplaySettings{});
  r = parse_command_line({"replay", "in.log", "--on=bench", "--loop", "--filter", "0x181:7ff", "--speed", "2.5"})
          .request;
  EXPECT_EQ(r.replay, (ReplaySettings{true, true, 0x181, 0x7FF, 2.5}));
  r = parse_command_line({"replay", "in.log", "--on", "bench", "--filter", "18DAF110"}).request;
  EXPECT_EQ(r.replay.filter_mask, 0x1FFFFFFFu);
  for (std::vector<std::string> bad : std::vector<std::vector<std::string>>{
           {"capture", "bench"},
           {"replay", "in.log"},
           {"replay", "in.log", "--on", "bench", "--speed", "0"},
           {"replay", "in.log", "--on", "bench", "--speed", "x"},
           {"replay", "in.log", "--on", "bench", "--filter", "1:zz"},
           {"replay", "in.log", "--on", "bench", "--filter", "20000000"},
       }) {
    try {
      parse_command_line(bad);
      ADD_FAILURE() << ::testing::PrintToString(bad);
    } catch (const UsageError& e) {
      EXPECT_EQ(e.verb, bad[0]) << e.what();
    }
  }
  EXPECT_NE(verb_help("replay").find("--filter ID[:MASK]: only frames with"), std::string::npos);
  EXPECT_NE(verb_help("capture").find("candump -L"), std::string::npos);
}

}  // namespace
}  // namespace cansim::ctl
