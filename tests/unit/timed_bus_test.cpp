// The loop core with a timed bus, on a fake clock: the exact schedule of a
// SYNC burst of mixed identifiers and lengths at 125 and 1000 kbit/s, frame by
// frame, how a frame from outside interleaves, late wake-ups, local delivery
// at the end of a frame, a full queue, and deadlines that do not drift.
//
// Frame lengths (bits incl. stuff bits and the 3-bit intermission) are
// io::wire_bits(), checked bit by bit in bus_model_test.cpp; each test also
// asserts the lengths it relies on. A frame starting at bit s of the schedule
// is written (to the transport, and heard by the other local nodes) when its
// EOF ends, at s + length - 3; the next starts at s + length.
#include <gtest/gtest.h>

#include "io/loop_core.hpp"
#include "io/wire_bits.hpp"
#include "support/sim.hpp"

namespace cansim::io {
namespace {

using test::F;
using Log = std::vector<std::pair<TimeUs, CanFrame>>;

Log frames(MemoryTransport& t) {
  Log out;
  for (auto& s : t.take()) out.emplace_back(s.time, s.frame);
  return out;
}

std::string dump(const Log& v) {
  std::string s;
  for (auto& [t, f] : v) s += std::to_string(t) + "us " + test::to_string(f) + "\n";
  return s;
}

// Sends its frames when it consumes a SYNC, and scripted frames at given times.
class Sender : public Application {
 public:
  std::vector<CanFrame> on_sync_frames;
  std::vector<std::pair<TimeUs, CanFrame>> script;  // sorted by time
  std::size_t next = 0;
  void on_sync(Node& node, std::uint8_t, TimeUs) override {
    for (const CanFrame& f : on_sync_frames) node.send(f);
  }
  TimeUs process(Node& node, TimeUs now) override {
    while (next < script.size() && script[next].first <= now) node.send(script[next++].second);
    return next < script.size() ? script[next].first : kNever;
  }
};

const CanFrame kSync = F(0x080, {});
const CanFrame kA1 = F(0x1A3, {0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88});
const CanFrame kA2 = F(0x1A3, {0, 0, 0, 0, 0, 0, 0, 0});
const CanFrame kB = F(0x181, {0x00, 0x00});
const CanFrame kC = F(0x192, {0xFF});
const CanFrame kD = F(0x185, {});
const CanFrame kE = F(0x2A1, {1, 2, 3, 4, 5, 6});
const CanFrame kSdoRequest = F(0x605, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});  // upload 0x1000 from node 5
const CanFrame kSdoResponse = F(0x585, {0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00});

// (bit-rate index, µs per bit): 125 and 1000 kbit/s.
class TimedBusTest : public ::testing::TestWithParam<std::pair<std::uint8_t, TimeUs>> {
 protected:
  static constexpr TimeUs kT0 = ms(10);  // the boot-ups are long over

  TimedBusTest() : profile(test::load_repo_profile("generic-404")), tx(&core.now()) {
    rate = GetParam().first;
    bit = GetParam().second;
    bus = core.add_bus("vcan0", tx, rate);
    core.set_bus_model(bus, BusModel::kTimed);
  }
  Sender& add(std::uint8_t id, std::vector<CanFrame> on_sync = {}) {
    auto app = std::make_unique<Sender>();
    app->on_sync_frames = std::move(on_sync);
    Sender& raw = *app;
    NodeSetup s = config::node_setup(profile, id);
    s.bit_rate_index = rate;
    refs.push_back(core.add_node(bus, s, std::move(app)));
    return raw;
  }
  // Nodes 1..4 and 6 answer a SYNC with the burst; node 5 is a plain
  // generic-404 (it answers SDO). Their boot-ups go out before kT0.
  void add_burst_fleet() {
    add(1, {kA1, kA2});  // two frames on one identifier: in the order sent
    add(2, {kB});
    add(3, {kC});
    add(4, {kD});
    add(5);
    add(6, {kE});
    for (NodeRef r : refs) core.power_on(r, 0);
    core.run_until(kT0 - 1);
    ASSERT_EQ(frames(tx).size(), 6u);
  }
  TimeUs at(int bits) const { return kT0 + bits * bit; }

  config::Profile profile;
  LoopCore core;
  MemoryTransport tx;
  BusId bus = 0;
  std::uint8_t rate = 0;
  TimeUs bit = 1;
  std::vector<NodeRef> refs;
};

TEST_P(TimedBusTest, SyncBurstLowestIdFirstBackToBack) {
  for (auto [f, bits] : {std::pair{kSync, 51}, {kB, 69}, {kD, 48}, {kC, 58}, {kA1, 113}, {kA2, 125}, {kE, 102}})
    ASSERT_EQ(wire_bits(f), bits) << test::to_string(f);
  add_burst_fleet();
  // The master's SYNC occupies the bus from its arrival, bits 0..51; every
  // node queues its answer at bit 0. Starts: 0x181 at 51, 0x185 at 51 + 69 =
  // 120, 0x192 at 168, 0x1A3 at 226 and (its second frame) 339, 0x2A1 at 464;
  // the bus is free again at 566.
  core.receive(bus, kSync, kT0);
  core.run_until(kT0 + ms(10));
  const Log want = {
      {at(51 + 66), kB}, {at(120 + 45), kD}, {at(168 + 55), kC}, {at(226 + 110), kA1}, {at(339 + 122), kA2}, {at(464 + 99), kE},
  };
  const Log got = frames(tx);
  EXPECT_EQ(got, want) << dump(got);
  const BusLoad load = core.bus_load(bus);
  EXPECT_EQ(load.model, BusModel::kTimed);
  EXPECT_EQ(load.delay_max, 464 * bit);  // 0x2A1 waited from bit 0 to bit 464
  EXPECT_EQ(load.queued, 0u);
  EXPECT_EQ(load.dropped, 0u);
}

TEST_P(TimedBusTest, AnOutsideFrameTakesTheBusAfterTheFrameOnTheWire) {
  ASSERT_EQ(wire_bits(kSdoRequest), 124);
  ASSERT_EQ(wire_bits(kSdoResponse), 119);
  add_burst_fleet();
  core.receive(bus, kSync, kT0);
  // The master's SDO request arrives at bit 125, while 0x185 (bits 120..168)
  // is on the wire: it takes bits 168..292. Node 5's answer, queued at 125,
  // has the highest identifier and goes last.
  core.run_until(at(125) - 1);
  core.receive(bus, kSdoRequest, at(125));
  core.run_until(kT0 + ms(20));
  Log want = {
      {at(51 + 66), kB},   {at(120 + 45), kD},  {at(292 + 55), kC},           {at(350 + 110), kA1},
      {at(463 + 122), kA2}, {at(588 + 99), kE}, {at(690 + 116), kSdoResponse},
  };
  Log got = frames(tx);
  EXPECT_EQ(got, want) << dump(got);

  // On an idle bus a frame from outside occupies it from its arrival, bits
  // 0..59 here. Node 7 boots (0x707) as it arrives and sends 0x185 10 bits
  // later: when the bus is free, 0x185 wins, queued later as it was.
  const CanFrame outside = F(0x77F, {0x05});
  const CanFrame boot_up = F(0x707, {0x00});
  ASSERT_EQ(wire_bits(outside), 59);
  ASSERT_EQ(wire_bits(boot_up), 60);
  const TimeUs t1 = kT0 + ms(30);
  core.run_until(t1 - 1);
  core.receive(bus, outside, t1);
  Sender& late = add(7);
  late.script = {{t1 + 10 * bit, kD}};
  core.power_on(refs.back(), t1);
  core.run_until(t1 + ms(10));
  got = frames(tx);
  want = {{t1 + (59 + 45) * bit, kD}, {t1 + (59 + 48 + 57) * bit, boot_up}};
  EXPECT_EQ(got, want) << dump(got);
}

TEST_P(TimedBusTest, ALateWakeUpSendsWhatEndedInOrderAndKeepsTheSchedule) {
  add_burst_fleet();
  core.receive(bus, kSync, kT0);
  // The loop wakes late, after 0x1A3's first frame ended (bit 336).
  core.run_due(at(400));
  Log got = frames(tx);
  EXPECT_EQ(got, (Log{{at(400), kB}, {at(400), kD}, {at(400), kC}, {at(400), kA1}})) << dump(got);
  EXPECT_EQ(core.next_deadline(), at(461));
  core.run_until(kT0 + ms(10));
  got = frames(tx);
  EXPECT_EQ(got, (Log{{at(461), kA2}, {at(563), kE}})) << dump(got);
}

TEST_P(TimedBusTest, OtherLocalNodesHearAFrameWhenItEnds) {
  const CanFrame start_all = F(0x000, {0x01, 0x00});
  ASSERT_EQ(wire_bits(start_all), 68);
  Sender& master = add(1);
  master.script = {{kT0, start_all}};
  add(2);
  for (NodeRef r : refs) core.power_on(r, 0);
  core.run_until(kT0 + 65 * bit - 1);
  EXPECT_EQ(core.node(refs[1]).state(), NmtState::kPreOperational);
  core.run_until(kT0 + 65 * bit);
  EXPECT_EQ(core.node(refs[1]).state(), NmtState::kOperational);
}

TEST_P(TimedBusTest, AFullQueueDropsAndCountsWhatItCannotHold) {
  add_burst_fleet();
  core.set_bus_model(bus, BusModel::kIdeal);
  core.set_bus_model(bus, BusModel::kTimed, 4);
  core.receive(bus, kSync, kT0);
  core.run_until(kT0 + ms(10));
  // Six frames at one instant, room for four: the last two the nodes sent
  // (they hear the SYNC in slot order, sending 0x1A3 0x1A3 0x181 0x192 0x185
  // 0x2A1) are lost. 0x181 starts at 51, 0x192 at 120, 0x1A3 at 178 and 291.
  const Log got = frames(tx);
  EXPECT_EQ(got, (Log{{at(51 + 66), kB}, {at(120 + 55), kC}, {at(178 + 110), kA1}, {at(291 + 122), kA2}})) << dump(got);
  core.run_until(ms(100));  // loads count complete 100 ms bins
  const BusLoad load = core.bus_load(bus);
  EXPECT_EQ(load.dropped, 2u);
  EXPECT_EQ(load.queue_capacity, 4u);
  EXPECT_GT(load.offered_1s, load.carried_1s);  // the dropped frames were offered
}

TEST_P(TimedBusTest, NodeDeadlinesDoNotDriftBehindABusyBus) {
  // Node 2's heartbeat of 100 ms (0x702), from the write at 1 ms, meets ten
  // frames on 0x100 each time: it leaves after them, 10 x 57 bits later, and
  // its period stays 100 ms.
  Sender& flood = add(1);
  for (int k = 1; k <= 5; ++k)
    for (int i = 0; i < 10; ++i) flood.script.push_back({ms(100) * k + ms(1), F(0x100, {0xAA})});
  add(2);
  for (NodeRef r : refs) core.power_on(r, 0);
  core.receive(bus, F(0x602, {0x2B, 0x17, 0x10, 0x00, 100, 0, 0, 0}), ms(1));  // 0x1017 = 100 ms
  core.run_until(ms(50));
  frames(tx);
  core.run_until(ms(550));
  std::vector<TimeUs> beats;
  for (auto& [t, f] : frames(tx))
    if (f.id == 0x702) beats.push_back(t);
  ASSERT_EQ(wire_bits(F(0x100, {0xAA})), 57);
  ASSERT_EQ(wire_bits(F(0x702, {0x7F})), 59) << "crc and stuffing of this heartbeat";
  std::vector<TimeUs> want;
  for (int k = 1; k <= 5; ++k) want.push_back(ms(100) * k + ms(1) + (570 + 56) * bit);
  EXPECT_EQ(beats, want);
}

TEST_P(TimedBusTest, SwitchingToIdealSendsWhatWaitsAtOnce) {
  add_burst_fleet();
  core.receive(bus, kSync, kT0);
  core.run_until(at(200));
  EXPECT_EQ(frames(tx).size(), 2u);  // 0x181 and 0x185 ended
  core.set_bus_model(bus, BusModel::kIdeal);
  EXPECT_EQ(frames(tx), (Log{{at(200), kC}, {at(200), kA1}, {at(200), kA2}, {at(200), kE}}));
  EXPECT_EQ(core.next_deadline(), ms(1000));  // the heartbeats: nothing waits for the bus
}

INSTANTIATE_TEST_SUITE_P(BitRates, TimedBusTest,
                         ::testing::Values(std::pair<std::uint8_t, TimeUs>{4, 8}, std::pair<std::uint8_t, TimeUs>{0, 1}),
                         [](const auto& info) { return info.param.first == 4 ? "kbit125" : "kbit1000"; });

}  // namespace
}  // namespace cansim::io
