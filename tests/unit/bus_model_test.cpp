// The parts of the timed bus: a frame's length on the wire (CRC-15 and stuff
// bits, ISO 11898-1), the arbitration order of waiting frames, and the
// traffic meter.
#include <gtest/gtest.h>

#include <map>
#include <random>
#include <vector>

#include "io/arbitration_queue.hpp"
#include "io/bus_meter.hpp"
#include "io/wire_bits.hpp"
#include "support/sim.hpp"

namespace cansim::io {
namespace {

using test::F;

CanFrame ext(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  CanFrame f = F(id, bytes);
  f.flags |= CanFrame::kExtended;
  return f;
}

// ---------------------------------------------------------------- reference

// The frame bit by bit, as ISO 11898-1 §10 draws it: SOF to the end of the data.
std::vector<int> frame_bits_unstuffed(const CanFrame& f) {
  std::vector<int> b{0};  // SOF
  auto put = [&](std::uint32_t v, int n) {
    for (int i = n - 1; i >= 0; --i) b.push_back(int((v >> i) & 1));
  };
  if (f.extended()) {
    put(f.id >> 18, 11);
    put(1, 1);  // SRR
    put(1, 1);  // IDE
    put(f.id & 0x3FFFF, 18);
    put(f.rtr(), 1);
    put(0, 2);  // r1 r0
  } else {
    put(f.id, 11);
    put(f.rtr(), 1);
    put(0, 2);  // IDE r0
  }
  put(f.dlc, 4);
  if (!f.rtr())
    for (int i = 0; i < f.dlc; ++i) put(f.data[i], 8);
  return b;
}

// The specification's CRC register, one bit at a time (§10.4.2.6).
std::uint16_t crc15_bitwise(const std::vector<int>& bits) {
  unsigned crc = 0;
  for (int bit : bits) {
    const unsigned next = unsigned(bit) ^ ((crc >> 14) & 1);
    crc = (crc << 1) & 0x7FFF;
    if (next) crc ^= 0x4599;
  }
  return std::uint16_t(crc);
}

int stuff_bits_bitwise(std::vector<int> bits, std::uint16_t crc) {
  for (int i = 14; i >= 0; --i) bits.push_back((crc >> i) & 1);
  int inserted = 0, last = -1, run = 0;
  for (int bit : bits) {
    run = bit == last ? run + 1 : 1;
    last = bit;
    if (run == 5) {  // the stuff bit, of the other value, starts the next run
      ++inserted;
      last = 1 - bit;
      run = 1;
    }
  }
  return inserted;
}

// ---------------------------------------------------------------- wire_bits

TEST(WireBits, AllZeroFrameByHand) {
  // ID 0x000, DLC 0: SOF, 11 ID bits, RTR, IDE, r0 and DLC are 19 zeros, so
  // the CRC register never leaves 0: 34 zeros to stuff, one stuff bit after
  // each 5 (after bits 5, 10, ..., 30): 6. 34 + 6 + CRC del, ACK 2, EOF 7 +
  // intermission 3 = 53 bits.
  const CanFrame f = F(0x000, {});
  EXPECT_EQ(crc15(f), 0);
  EXPECT_EQ(stuffable_bits(f), 34);
  EXPECT_EQ(stuff_bits(f), 6);
  EXPECT_EQ(wire_bits(f), 53);
}

TEST(WireBits, EightZeroBytesHaveManyStuffBits) {
  // ID 0x000, DLC 8, eight zero bytes: 15 zeros (SOF..r0), DLC 1000, 64 zeros,
  // CRC 0x145B = 001 0100 0101 1011. Stuff bits: 3 in the first 15 zeros (the
  // last one, a 1, runs on into DLC's 1); 13 in the 67 zeros of DLC and data
  // (after zeros 5..65); the 2 zeros left and the CRC's 00 make 4, then the
  // CRC has no run of 5: 16. 98 + 16 + 13 = 127 bits (8 random-looking bytes:
  // 113).
  const CanFrame f = F(0x000, {0, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(crc15(f), 0x145B);
  EXPECT_EQ(stuff_bits(f), 16);
  EXPECT_EQ(wire_bits(f), 127);
}

TEST(WireBits, ProtocolFramesOfThisProject) {
  // CRC and length as the bitwise reference above computes them.
  struct Case {
    CanFrame frame;
    std::uint16_t crc;
    int stuff, bits;
  };
  const Case cases[] = {
      {F(0x080, {}), 0x1C05, 4, 51},                                                 // SYNC
      {F(0x701, {0x7F}), 0x72DE, 4, 59},                                             // heartbeat, pre-operational
      {F(0x701, {0x05}), 0x4D0E, 3, 58},                                             // heartbeat, operational
      {F(0x581, {0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}), 0x2714, 9, 120},  // SDO upload response
      {F(0x7FF, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF}), 0x4C89, 15, 126},
      {CanFrame::remote(0x701), 0x3C79, 2, 49},  // guarding RTR
      {ext(0x1ABCDEF0, {1, 2, 3}), 0x0738, 5, 96},
      {ext(0x1FFFFFFF, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF}), 0x1B69, 18, 149},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(test::to_string(c.frame));
    EXPECT_EQ(crc15(c.frame), c.crc);
    EXPECT_EQ(stuff_bits(c.frame), c.stuff);
    EXPECT_EQ(wire_bits(c.frame), c.bits);
  }
}

TEST(WireBits, RemoteFrameSendsItsDlcButNoData) {
  CanFrame r = CanFrame::remote(0x181, 8);
  EXPECT_EQ(stuffable_bits(r), 34);
  EXPECT_EQ(crc15(r), crc15_bitwise(frame_bits_unstuffed(r)));
  EXPECT_NE(crc15(r), crc15(CanFrame::remote(0x181, 0)));  // the DLC is in the CRC
}

TEST(WireBits, TablesMatchTheBitwiseReferenceAndStayWithinTheWorstCase) {
  std::mt19937 rng(27);
  int longest_standard = 0;
  for (int i = 0; i < 20000; ++i) {
    CanFrame f;
    f.flags = std::uint8_t((rng() % 4 == 0 ? CanFrame::kExtended : 0) | (rng() % 8 == 0 ? CanFrame::kRtr : 0));
    f.id = f.extended() ? rng() & 0x1FFFFFFF : rng() & 0x7FF;
    f.dlc = std::uint8_t(rng() % 9);
    // Runs of equal bits are what stuffing is about: mostly 0x00 / 0xFF bytes.
    for (auto& b : f.data) b = std::uint8_t(rng() % 3 == 0 ? rng() : (rng() % 2 ? 0xFF : 0x00));
    const std::vector<int> bits = frame_bits_unstuffed(f);
    const std::uint16_t crc = crc15_bitwise(bits);
    ASSERT_EQ(crc15(f), crc) << test::to_string(f);
    ASSERT_EQ(stuff_bits(f), stuff_bits_bitwise(bits, crc)) << test::to_string(f);
    const int data = f.rtr() ? 0 : f.dlc;
    const int stuffable = (f.extended() ? 54 : 34) + 8 * data;
    ASSERT_EQ(stuffable_bits(f), stuffable);
    ASSERT_LE(stuff_bits(f), (stuffable - 1) / 4);  // ISO 11898-1 worst case
    ASSERT_EQ(unstuffed_wire_bits(f), (f.extended() ? 67 : 47) + 8 * data);
    if (!f.extended() && data == 8) longest_standard = std::max(longest_standard, wire_bits(f));
  }
  EXPECT_LE(longest_standard, 135);
  EXPECT_GT(longest_standard, 111 + 12);  // the zeros above reach deep into the stuffing
}

// ---------------------------------------------------------------- arbitration

TEST(ArbitrationQueue, LowestIdentifierWinsAsOnTheWire) {
  ArbitrationQueue q(16);
  // 11-bit data frame < 11-bit remote frame < 29-bit frames of the same base
  // identifier (RTR vs SRR, then IDE); 29-bit frames by their 18 extension bits.
  const CanFrame order[] = {F(0x100, {1}), CanFrame::remote(0x100), ext(0x100u << 18, {}), ext((0x100u << 18) | 1, {}),
                            F(0x101, {}),  ext(0x101u << 18, {}),   F(0x7FF, {})};
  for (int i = 6; i >= 0; --i) ASSERT_TRUE(q.push({order[i], 0, std::uint32_t(i), 50}));
  for (const CanFrame& f : order) {
    ASSERT_FALSE(q.empty());
    EXPECT_EQ(q.top().frame, f) << test::to_string(q.top().frame);
    q.pop();
  }
  EXPECT_TRUE(q.empty());
}

TEST(ArbitrationQueue, EqualIdentifiersLeaveInQueueOrderAndAFullQueueRefuses) {
  ArbitrationQueue q(3);
  EXPECT_TRUE(q.push({F(0x581, {1}), 0, 0, 0}));
  EXPECT_TRUE(q.push({F(0x581, {2}), 0, 0, 0}));
  EXPECT_TRUE(q.push({F(0x181, {3}), 0, 0, 0}));
  EXPECT_FALSE(q.push({F(0x080, {}), 0, 0, 0}));
  EXPECT_EQ(q.size(), 3u);
  std::vector<std::uint8_t> got;
  for (; !q.empty(); q.pop()) got.push_back(q.top().frame.data[0]);
  EXPECT_EQ(got, (std::vector<std::uint8_t>{3, 1, 2}));
  EXPECT_TRUE(q.push({F(0x080, {}), 0, 0, 0}));  // room again
}

TEST(ArbitrationQueue, MatchesASortedModelUnderRandomTraffic) {
  ArbitrationQueue q(64);
  std::multimap<std::pair<std::uint32_t, std::uint64_t>, CanFrame> model;  // (key, order) -> frame
  std::mt19937 rng(5);
  std::uint64_t order = 0;
  for (int step = 0; step < 50000; ++step) {
    if (rng() % 2 == 0) {
      CanFrame f = F(rng() % 16 + 0x180, {std::uint8_t(step)});
      if (rng() % 5 == 0) f = ext((rng() % 16 + 0x180) << 18 | (rng() % 4), {std::uint8_t(step)});
      if (rng() % 7 == 0) f.flags |= CanFrame::kRtr;
      const bool room = model.size() < 64;
      ASSERT_EQ(q.push({f, 0, 0, 0}), room);
      if (room) model.emplace(std::make_pair(ArbitrationQueue::key(f), order++), f);
    } else if (!model.empty()) {
      ASSERT_EQ(q.top().frame, model.begin()->second) << "step " << step;
      q.pop();
      model.erase(model.begin());
    }
    ASSERT_EQ(q.size(), model.size());
  }
}

// ---------------------------------------------------------------- meter

TEST(BusMeter, LoadsOverOneAndTenSecondsEndNow) {
  BusMeter m;
  m.reset(0);
  // 1000 bits every 10 ms for 10 s: 100 kbit/s; then 1 s of silence.
  for (TimeUs t = 0; t < 10'000'000; t += 10'000) {
    m.offered(1000, t);
    m.carried(1000, t);
  }
  BusMeter::Figures f = m.figures(10'000'000);
  EXPECT_NEAR(f.offered_1s, 100'000, 1);
  EXPECT_NEAR(f.carried_10s, 100'000, 1);
  f = m.figures(11'050'000);
  EXPECT_EQ(f.carried_1s, 0);
  EXPECT_NEAR(f.carried_10s, 90'000, 1);  // 1 .. 11 s: 9 s of traffic
  f = m.figures(10'099'999);              // complete bins only: the same as at 10 s
  EXPECT_NEAR(f.offered_1s, 100'000, 1);

  BusMeter young;  // half a second after its start: over that half second
  young.reset(0);
  for (TimeUs t = 0; t < 500'000; t += 10'000) young.offered(1000, t);
  f = young.figures(500'000);
  EXPECT_NEAR(f.offered_1s, 100'000, 1);
  EXPECT_NEAR(f.offered_10s, 100'000, 1);
  EXPECT_EQ(f.carried_1s, 0);
}

TEST(BusMeter, DelayPercentilesByNearestRank) {
  BusMeter m;
  m.reset(0);
  for (int i = 1; i <= 100; ++i) m.delay(i < 100 ? 10 : 5000, TimeUs(i) * 1000);
  BusMeter::Figures f = m.figures(200'000);
  EXPECT_EQ(f.delayed, 100u);
  EXPECT_EQ(f.delay_p50, 10);  // below 16 µs, exact
  EXPECT_EQ(f.delay_p99, 10);
  EXPECT_EQ(f.delay_max, 5000);
  m.delay(3000, 300'000);
  f = m.figures(300'000);
  EXPECT_EQ(f.delay_p99, 3071);  // the upper bound of 3000's bucket [2816, 3071]
  EXPECT_GE(f.delay_p99, 3000);
  EXPECT_LE(double(f.delay_p99), 3000 * 1.125);
  f = m.figures(10'500'000);  // those delays are older than 10 s
  EXPECT_EQ(f.delayed, 0u);
  EXPECT_EQ(f.delay_max, 0);
}

}  // namespace
}  // namespace cansim::io
