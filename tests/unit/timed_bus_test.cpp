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
  // Node 1 starts every node at kT0; node 2 hears it when its EOF ends, 65
  // bits later (68 on the wire less the intermission), not before.
  void expect_heard_when_it_ends() {
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
      {at(51 + 66), kB},    {at(120 + 45), kD},   {at(168 + 55), kC},
      {at(226 + 110), kA1}, {at(339 + 122), kA2}, {at(464 + 99), kE},
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
      {at(51 + 66), kB},
      {at(120 + 45), kD},
      {at(292 + 55), kC},
      {at(350 + 110), kA1},
      {at(463 + 122), kA2},
      {at(588 + 99), kE},
      {at(690 + 116), kSdoResponse},
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

// Records who sent each frame: a local node (0) or an outside participant.
class ParticipantLog : public Transport {
 public:
  explicit ParticipantLog(const TimeUs* clock) : clock_(clock) {}
  void transmit(const CanFrame& f) override { log.push_back({*clock_, f, 0}); }
  void transmit_from(const CanFrame& f, Participant from) override { log.push_back({*clock_, f, from}); }
  struct Entry {
    TimeUs time;
    CanFrame frame;
    Participant from;
    bool operator==(const Entry&) const = default;
  };
  std::vector<Entry> log;

 private:
  const TimeUs* clock_;
};

TEST_P(TimedBusTest, AParticipantsFramesArbitrateWithTheNodesAndReachThemWhenTheyEnd) {
  LoopCore wire;
  ParticipantLog out(&wire.now());
  const BusId b = wire.add_bus("bench", out, rate);
  wire.set_bus_model(b, BusModel::kTimed);
  auto add_node = [&](std::uint8_t id, std::vector<CanFrame> on_sync) {
    auto app = std::make_unique<Sender>();
    app->on_sync_frames = std::move(on_sync);
    NodeSetup s = config::node_setup(profile, id);
    s.bit_rate_index = rate;
    wire.power_on(wire.add_node(b, s, std::move(app)), 0);
  };
  add_node(1, {kA1});
  add_node(2, {kB});
  add_node(5, {});  // answers SDO
  wire.run_until(kT0 - 1);
  out.log.clear();
  // A SYNC seen on the wire (bits 0..51); participant 9 submits at the same
  // instant a frame that wins (0x100) and an SDO request that loses to every
  // node's frame (0x605). Node 5 hears the request when it ends and answers.
  const CanFrame low = F(0x100, {0x01});
  wire.receive(b, kSync, kT0);
  EXPECT_TRUE(wire.submit(b, low, 9, kT0));
  EXPECT_TRUE(wire.submit(b, kSdoRequest, 9, kT0));
  wire.run_until(kT0 + ms(20));
  std::vector<ParticipantLog::Entry> want;
  int start = wire_bits(kSync);
  for (auto [f, from] : {std::pair{low, 9u}, {kB, 0u}, {kA1, 0u}, {kSdoRequest, 9u}, {kSdoResponse, 0u}}) {
    want.push_back({at(start + wire_bits(f) - 3), f, Participant(from)});
    start += wire_bits(f);
  }
  EXPECT_EQ(out.log, want);
  const BusLoad load = wire.bus_load(b);
  EXPECT_EQ(load.dropped, 0u);
  EXPECT_EQ(wire.stats().frames_in, 3u);  // the SYNC and two submitted
}

TEST_P(TimedBusTest, AParticipantsFrameIsOnAnIdealBusAtOnce) {
  LoopCore wire;
  ParticipantLog out(&wire.now());
  const BusId b = wire.add_bus("bench", out, rate);
  NodeSetup s = config::node_setup(profile, 5);
  s.bit_rate_index = rate;
  wire.power_on(wire.add_node(b, s), 0);
  wire.run_until(kT0 - 1);
  out.log.clear();
  EXPECT_TRUE(wire.submit(b, kSdoRequest, 3, kT0));
  EXPECT_EQ(out.log, (std::vector<ParticipantLog::Entry>{{kT0, kSdoRequest, 3}, {kT0, kSdoResponse, 0}}));
}

TEST_P(TimedBusTest, ALateWakeUpSlipsTheBusNeverFasterThanTheFrames) {
  add_burst_fleet();
  core.receive(bus, kSync, kT0);
  // The loop wakes late, at bit 400: 0x181 ended at bit 117 and leaves now;
  // the bus slips by 283 bits, and each frame after it follows for its own
  // length (0x185 48 bits, 0x192 58, 0x1A3 113 and 125, 0x2A1 102), not at
  // once as the schedule would catch up.
  core.run_due(at(400));
  Log got = frames(tx);
  EXPECT_EQ(got, (Log{{at(400), kB}})) << dump(got);
  EXPECT_EQ(core.next_deadline(), at(403 + 45));
  core.run_until(kT0 + ms(10));
  got = frames(tx);
  EXPECT_EQ(got,
            (Log{{at(448), kD}, {at(451 + 55), kC}, {at(509 + 110), kA1}, {at(622 + 122), kA2}, {at(747 + 99), kE}}))
      << dump(got);
  const BusLoad load = core.bus_load(bus);
  EXPECT_EQ(load.slip_max, 283 * bit);
  EXPECT_EQ(load.slip_p99, 283 * bit);   // 1 frame in 6 slipped: the top 1 %
  EXPECT_EQ(load.delay_max, 747 * bit);  // 0x2A1 queued at 0, started at 747
}

TEST_P(TimedBusTest, AnOutsideFloodHoldsTheBusOnlyAsRealTimeAllows) {
  // 0x7FF with 8 bytes every 30 bit times for 1 s: about 4.4 times what the
  // bus carries. Node 1 sends 0x181 in the middle of it.
  const CanFrame flood = F(0x7FF, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF});
  const int flood_bits = wire_bits(flood);
  ASSERT_EQ(flood_bits, 126);
  Sender& node = add(1);
  for (NodeRef r : refs) core.power_on(r, 0);
  const TimeUs t1 = ms(100), t2 = ms(1100);
  node.script = {{ms(600), kB}};
  core.run_until(t1 - 1);
  frames(tx);
  TimeUs last = t1;
  for (TimeUs t = t1; t < t2; t += 30 * bit) {
    core.run_until(t);
    core.receive(bus, flood, t);
    last = t;
    // The bus's time never runs more than one frame ahead of the clock:
    // 0x181 would end at most that frame and its own after now.
    if (t >= ms(600)) {
      EXPECT_LE(core.next_deadline(), t + (flood_bits + 66) * bit) << t;
    }
  }
  core.run_until(t2 + ms(10));
  // 0x181 starts when the last outside frame is over and ends 66 bits
  // later; the heartbeat node 1 queued at 1 s during the flood follows it.
  const CanFrame beat = F(0x701, {0x7F});
  EXPECT_EQ(frames(tx),
            (Log{{last + (flood_bits + 66) * bit, kB}, {last + (flood_bits + 69 + wire_bits(beat) - 3) * bit, beat}}));
  const BusLoad load = core.bus_load(bus);  // the last complete second: the flood
  EXPECT_NEAR(load.offered_1s, double(flood_bits) / 30, 0.05);
  EXPECT_LE(load.carried_1s, 1.0);
  EXPECT_GE(load.carried_1s, 0.99);
}

TEST_P(TimedBusTest, NmtPreOperationalWithdrawsTheQueuedPdos) {
  // Nodes 1..6 answer a SYNC with a frame on their TPDO1 COB-ID (0x180 +
  // node-ID). The master's "enter pre-operational" arrives while the first
  // is on the wire: that one leaves, the five others never do (their
  // controllers dropped what the new state does not send).
  std::vector<CanFrame> tpdos;
  for (std::uint8_t id = 1; id <= 6; ++id) {
    tpdos.push_back(F(0x180 + id, {id, 0, 0, 0, 0, 0, 0, 0}));
    add(id, {tpdos.back()});
  }
  for (NodeRef r : refs) core.power_on(r, 0);
  core.receive(bus, F(0x000, {0x01, 0x00}), kT0 - ms(5));  // start all
  core.run_until(kT0 - 1);
  frames(tx);
  core.receive(bus, kSync, kT0);
  const int first = wire_bits(tpdos[0]);
  core.run_until(at(51 + 20));
  core.receive(bus, F(0x000, {0x80, 0x00}), at(51 + 20));
  core.run_until(kT0 + ms(50));
  EXPECT_EQ(frames(tx), (Log{{at(51 + first - 3), tpdos[0]}}));
  for (NodeRef r : refs) EXPECT_EQ(core.node(r).state(), NmtState::kPreOperational);
  EXPECT_EQ(core.bus_load(bus).queued, 0u);
}

TEST_P(TimedBusTest, PowerOffAndRemovalWithdrawTheNodesFrames) {
  add_burst_fleet();
  core.receive(bus, kSync, kT0);
  core.run_until(at(100));  // 0x181 ended, 0x185 on the wire
  // Node 3 (0x192) loses power, node 6 (0x2A1) is removed: their frames
  // never leave; node 4's 0x185 was on the wire and does.
  core.node(refs[2]).power_cycle(at(100), ms(500));
  core.refresh(refs[2]);
  core.remove_node(refs[5]);
  core.run_until(kT0 + ms(10));
  const Log got = frames(tx);
  EXPECT_EQ(got, (Log{{at(51 + 66), kB}, {at(120 + 45), kD}, {at(168 + 110), kA1}, {at(281 + 122), kA2}})) << dump(got);
}

TEST_P(TimedBusTest, OtherLocalNodesHearAFrameWhenItEnds) { expect_heard_when_it_ends(); }

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

// The same buses handed to a transport that paces them itself (SO_TXTIME
// and the ETF qdisc): a burst is handed over at once, each frame with the
// time its EOF ends; the other local nodes still hear it then.
class PacedTimedBusTest : public TimedBusTest {
 protected:
  PacedTimedBusTest() {
    tx.paced = true;
    core.update_pacer(bus);
  }
  using Launches = std::vector<std::tuple<TimeUs, std::int64_t, CanFrame>>;  // handed over, launch, frame
  Launches launches() {
    Launches out;
    for (auto& s : tx.take()) out.emplace_back(s.time, s.launch_ns, s.frame);
    return out;
  }
  std::int64_t end_ns(int bits) const { return at(bits) * 1000; }
  void expect_burst_handed_over();
};

TEST_P(PacedTimedBusTest, ABurstIsHandedOverAtOnceWithItsSchedule) { expect_burst_handed_over(); }

void PacedTimedBusTest::expect_burst_handed_over() {
  EXPECT_EQ(core.bus_pacer(bus), Pacer::kAhead);
  add_burst_fleet();
  core.receive(bus, kSync, kT0);
  const Launches want = {
      {kT0, end_ns(51 + 66), kB},    {kT0, end_ns(120 + 45), kD},   {kT0, end_ns(168 + 55), kC},
      {kT0, end_ns(226 + 110), kA1}, {kT0, end_ns(339 + 122), kA2}, {kT0, end_ns(464 + 99), kE},
  };
  EXPECT_EQ(launches(), want);
  // The loop comes back only where a local node hears a frame (node 1
  // answers remote requests on 0x181, node 5 on 0x185) and when the last
  // one ended (the queue's figures).
  std::vector<TimeUs> wake_ups;
  for (TimeUs t = core.next_deadline(); t <= kT0 + ms(10); t = core.next_deadline()) {
    wake_ups.push_back(t);
    core.run_due(t);
  }
  EXPECT_EQ(wake_ups, (std::vector<TimeUs>{at(51 + 66), at(120 + 45), at(464 + 99)}));
  EXPECT_TRUE(launches().empty());
  EXPECT_EQ(core.bus_load(bus).queued, 0u);
  EXPECT_EQ(core.bus_load(bus).delay_max, 464 * bit);
}

TEST_P(PacedTimedBusTest, OtherLocalNodesHearAFrameWhenItEnds) { expect_heard_when_it_ends(); }

TEST_P(PacedTimedBusTest, ALongQueueIsHandedOverInBatchesAhead) {
  // 64 frames at once, 1.7 to 13.8 ms of bus at 125 / 1000 kbit/s: each
  // pass hands over what starts within 4 ms, and comes back when less
  // than 1 ms of it is left.
  Sender& node = add(1);
  for (int i = 0; i < 64; ++i) node.script.push_back({kT0, F(0x300, {std::uint8_t(i)})});
  for (NodeRef r : refs) core.power_on(r, 0);
  core.run_until(kT0 - 1);
  launches();
  core.run_until(kT0 + ms(100));
  const Launches got = launches();
  ASSERT_EQ(got.size(), 64u);
  for (std::size_t i = 0; i < got.size(); ++i) {
    const auto& [handed, launch, f] = got[i];
    EXPECT_EQ(f.data[0], i);
    const std::int64_t start = launch - (wire_bits(f) - 3) * bit * 1000;
    EXPECT_LE(start - handed * 1000, TimedBus::kDefaultHorizonNs) << i;  // never more than 4 ms ahead
    EXPECT_GE(start, handed * 1000) << i;
    if (i > 0) {
      EXPECT_EQ(launch - std::get<1>(got[i - 1]), wire_bits(f) * bit * 1000) << i;  // back to back
    }
  }
}

// A bus whose transport carries nothing (a kernel interface down or
// missing): nobody can see when a frame ends but the other local nodes, so
// the frames are handed over ahead as to a pacing transport (which drops
// them), with the same schedule and one wake-up a batch instead of a frame.
class OfflineTimedBusTest : public PacedTimedBusTest {
 protected:
  OfflineTimedBusTest() {
    tx.paced = false;
    tx.carrying = false;
    core.update_pacer(bus);
  }
  // The loop's passes until the bus has nothing left, from kT0.
  std::vector<TimeUs> passes_until_idle() {
    std::vector<TimeUs> out;
    for (TimeUs t = core.next_deadline(); core.bus_load(bus).queued > 0; t = core.next_deadline()) {
      out.push_back(t);
      core.run_due(t);
    }
    return out;
  }
};

TEST_P(OfflineTimedBusTest, ABurstIsHandedOverAtOnceWithItsSchedule) { expect_burst_handed_over(); }

TEST_P(OfflineTimedBusTest, OtherLocalNodesHearAFrameWhenItEnds) { expect_heard_when_it_ends(); }

TEST_P(OfflineTimedBusTest, ALongQueueWakesTheLoopOnceABatchNotOnceAFrame) {
  // 64 frames at once (29.2 ms of bus at 125 kbit/s, 3.6 ms at 1 Mbit/s),
  // back to back: handed over up to 4 ms ahead, the loop back 1 ms before
  // the first frame not handed over starts (every 3-3.5 ms) and at the end.
  const CanFrame f = F(0x300, {0x55});
  const int len = wire_bits(f);
  ASSERT_EQ(len, 57);
  Sender& node = add(1);
  for (int i = 0; i < 64; ++i) node.script.push_back({kT0, f});
  for (NodeRef r : refs) core.power_on(r, 0);
  core.run_until(kT0 - 1);
  launches();
  ASSERT_EQ(core.next_deadline(), kT0);
  core.run_due(kT0);
  const std::vector<TimeUs> passes = passes_until_idle();
  const Launches got = launches();
  ASSERT_EQ(got.size(), 64u);
  for (std::size_t i = 0; i < got.size(); ++i)
    EXPECT_EQ(std::get<1>(got[i]), (kT0 + (TimeUs(i + 1) * len - 3) * bit) * 1000) << i;
  const TimeUs last_end = kT0 + (64 * len - 3) * bit;
  ASSERT_FALSE(passes.empty());
  EXPECT_EQ(passes.back(), last_end);
  TimeUs before = kT0;
  for (std::size_t i = 0; i + 1 < passes.size(); ++i) {
    EXPECT_GT(passes[i] - before, ms(3)) << i;  // 1 ms before the first frame not handed over
    EXPECT_LE(passes[i] - before, ms(3) + len * bit) << i;
    before = passes[i];
  }
  EXPECT_EQ(passes.size(), bit == 8 ? 9u : 1u);  // 64 wake-ups when the loop paces
}

TEST_P(OfflineTimedBusTest, AnInterfaceThatGoesDownOrComesBackKeepsTheSchedule) {
  // The interface carries: the loop writes kB at its end. It goes down: the
  // rest of the burst is handed over with the same schedule (to nobody).
  tx.carrying = true;
  core.update_pacer(bus);
  ASSERT_EQ(core.bus_pacer(bus), Pacer::kLoop);
  add_burst_fleet();
  core.receive(bus, kSync, kT0);
  core.run_until(at(51 + 66));
  EXPECT_EQ(frames(tx), (Log{{at(51 + 66), kB}}));
  tx.carrying = false;
  core.update_pacer(bus);
  EXPECT_EQ(core.bus_pacer(bus), Pacer::kAhead);
  core.run_until(at(51 + 66));
  const Launches want = {{at(51 + 66), end_ns(120 + 45), kD},
                         {at(51 + 66), end_ns(168 + 55), kC},
                         {at(51 + 66), end_ns(226 + 110), kA1},
                         {at(51 + 66), end_ns(339 + 122), kA2},
                         {at(51 + 66), end_ns(464 + 99), kE}};
  EXPECT_EQ(launches(), want);
  // Up again at bit 200: kD ended while it was down; the frames handed over
  // that end later are written at their ends, as the loop would have.
  core.run_until(at(200));
  tx.carrying = true;
  core.update_pacer(bus);
  EXPECT_EQ(core.bus_pacer(bus), Pacer::kLoop);
  core.run_until(ms(20));
  EXPECT_EQ(frames(tx), (Log{{at(168 + 55), kC}, {at(226 + 110), kA1}, {at(339 + 122), kA2}, {at(464 + 99), kE}}));
  EXPECT_EQ(tx.recalled_frames, 4u);  // each counted lost when handed over, and on the wire after all
  // A participant's frame takes the idle bus at once. Down while it is on
  // the wire: it still leaves at its end, written by the loop.
  core.submit(bus, kE, 1, ms(20));
  const TimeUs end = ms(20) + (wire_bits(kE) - 3) * bit;
  core.run_until(ms(20) + 10 * bit);
  tx.carrying = false;
  core.update_pacer(bus);
  core.run_until(end - 1);
  EXPECT_TRUE(tx.take().empty());
  core.run_until(end);
  EXPECT_EQ(launches(), (Launches{{end, -1, kE}}));
  // Up again: each frame of a burst is written at its end.
  tx.carrying = true;
  core.update_pacer(bus);
  core.run_until(ms(30));
  core.receive(bus, kSync, ms(30));
  core.run_until(ms(40));
  const Log written = frames(tx);
  ASSERT_EQ(written.size(), 6u) << dump(written);
  EXPECT_EQ(written[0], std::make_pair(ms(30) + (51 + 66) * bit, kB));
  EXPECT_EQ(written[5], std::make_pair(ms(30) + (464 + 99) * bit, kE));
}

TEST_P(OfflineTimedBusTest, AnInterfaceBackWithTheKernelsPacerWritesWhatEndsLaterAtItsEnd) {
  // Down, the burst was handed to nobody; back at bit 200 with the
  // kernel's pacer (still ahead): what ends later is written at its end.
  tx.paced = true;
  core.update_pacer(bus);
  add_burst_fleet();
  core.receive(bus, kSync, kT0);
  core.run_until(at(200));
  ASSERT_EQ(launches().size(), 6u);
  tx.carrying = true;
  core.update_pacer(bus);
  EXPECT_EQ(core.bus_pacer(bus), Pacer::kAhead);
  core.run_until(ms(20));
  EXPECT_EQ(
      launches(),
      (Launches{{at(168 + 55), -1, kC}, {at(226 + 110), -1, kA1}, {at(339 + 122), -1, kA2}, {at(464 + 99), -1, kE}}));
  EXPECT_EQ(tx.recalled_frames, 4u);
}

TEST_P(OfflineTimedBusTest, SwitchingToIdealWritesTheRecalledFramesAtOnce) {
  // Handed over while the interface was down, recalled when it came back:
  // a switch to ideal before they end writes them at once, in their order.
  add_burst_fleet();
  core.receive(bus, kSync, kT0);
  core.run_until(kT0);
  ASSERT_EQ(launches().size(), 6u);
  tx.carrying = true;
  core.update_pacer(bus);
  core.set_bus_model(bus, BusModel::kIdeal);
  EXPECT_EQ(frames(tx), (Log{{kT0, kB}, {kT0, kD}, {kT0, kC}, {kT0, kA1}, {kT0, kA2}, {kT0, kE}}));
  EXPECT_EQ(tx.recalled_frames, 6u);
  core.run_until(ms(20));
  EXPECT_TRUE(frames(tx).empty());  // none again at its end
}

INSTANTIATE_TEST_SUITE_P(BitRates, OfflineTimedBusTest,
                         ::testing::Values(std::pair<std::uint8_t, TimeUs>{4, 8},
                                           std::pair<std::uint8_t, TimeUs>{0, 1}),
                         [](const auto& info) { return info.param.first == 4 ? "kbit125" : "kbit1000"; });

INSTANTIATE_TEST_SUITE_P(BitRates, PacedTimedBusTest,
                         ::testing::Values(std::pair<std::uint8_t, TimeUs>{4, 8},
                                           std::pair<std::uint8_t, TimeUs>{0, 1}),
                         [](const auto& info) { return info.param.first == 4 ? "kbit125" : "kbit1000"; });

INSTANTIATE_TEST_SUITE_P(BitRates, TimedBusTest,
                         ::testing::Values(std::pair<std::uint8_t, TimeUs>{4, 8},
                                           std::pair<std::uint8_t, TimeUs>{0, 1}),
                         [](const auto& info) { return info.param.first == 4 ? "kbit125" : "kbit1000"; });

}  // namespace
}  // namespace cansim::io
