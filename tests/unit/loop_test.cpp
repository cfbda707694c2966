// Loop core stepped with a fake clock and an in-memory transport: deadline
// ordering across nodes, absolute (drift-free) schedules, local delivery to
// the other nodes of a bus, no re-entrant delivery.
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "io/deadline_heap.hpp"
#include "io/loop_core.hpp"
#include "support/sim.hpp"

namespace cansim::io {
namespace {

using test::F;

std::vector<std::pair<TimeUs, CanFrame>> frames(MemoryTransport& t) {
  std::vector<std::pair<TimeUs, CanFrame>> out;
  for (auto& s : t.take()) out.emplace_back(s.time, s.frame);
  return out;
}

std::string dump(const std::vector<std::pair<TimeUs, CanFrame>>& v) {
  std::string s;
  for (auto& [t, f] : v) s += std::to_string(t) + "us " + test::to_string(f) + "\n";
  return s;
}

// Sends scripted frames at given times and counts its callbacks.
class ScriptApp : public Application {
 public:
  std::vector<std::pair<TimeUs, CanFrame>> script;  // sorted by time
  std::size_t next = 0;
  TimeUs process(Node& node, TimeUs now) override {
    while (next < script.size() && script[next].first <= now) node.send(script[next++].second);
    return next < script.size() ? script[next].first : kNever;
  }
};

// Answers every SYNC with a SYNC of its own until the shared budget runs
// out, recording whether a callback was ever entered while another ran.
struct PingPong {
  int depth = 0;
  int max_depth = 0;
  int budget = 6;
};
class SyncEcho : public ScriptApp {
 public:
  explicit SyncEcho(PingPong& p) : p_(p) {}
  void on_sync(Node& node, std::uint8_t, TimeUs) override {
    ++p_.depth;
    p_.max_depth = std::max(p_.max_depth, p_.depth);
    if (p_.budget-- > 0) node.send(F(0x080, {}));
    --p_.depth;
  }

 private:
  PingPong& p_;
};

class LoopTest : public ::testing::Test {
 protected:
  LoopTest() : profile(test::load_repo_profile("generic-404")), tx(&core.now()) { bus = core.add_bus("vcan0", tx, 3); }
  NodeRef add(std::uint8_t id, std::unique_ptr<Application> app = nullptr) {
    return core.add_node(bus, config::node_setup(profile, id), std::move(app));
  }
  // Expedited SDO download of a u16 from the master.
  void write_u16(std::uint8_t id, std::uint16_t index, std::uint8_t sub, std::uint16_t v, TimeUs at) {
    core.receive(bus,
                 F(0x600 + id, {0x2B, std::uint8_t(index), std::uint8_t(index >> 8), sub, std::uint8_t(v),
                                std::uint8_t(v >> 8), 0, 0}),
                 at);
  }

  config::Profile profile;
  LoopCore core;
  MemoryTransport tx;
  BusId bus;
};

// Against a brute-force minimum, in three regimes: random deadlines (mostly
// the heap), a rotating fleet where the node that ran gets a later deadline
// (mostly the run, with its dead entries), a mix, and a run whose first node
// never runs (dead entries pile up behind it until the ring is compacted).
void check_deadline_heap(int regime) {
  DeadlineHeap h;
  const std::uint32_t slots = 50;
  h.reserve_slots(slots);
  std::map<std::uint32_t, TimeUs> ref;
  std::mt19937 rng(7 + regime);
  TimeUs now = 0;
  for (int step = 0; step < 20000; ++step) {
    std::uint32_t slot = rng() % slots;
    TimeUs t = TimeUs(rng() % 1000) + now;
    if (regime == 3) {
      // Slot 0 stays first; the others are rescheduled later and later,
      // leaving dead entries behind it until the ring is compacted.
      slot = step == 0 ? 0 : 1 + rng() % (slots - 1);
      t = step;
    } else if (regime >= 1 && !ref.empty() && rng() % 4 != 0) {
      slot = h.top();  // the node that ran
      now = h.top_time();
      t = now + (regime == 1 ? 100 : TimeUs(rng() % 3) * 50);
    }
    if (rng() % 10 == 0 && slot != 0) t = kNever;
    h.set(slot, t);
    if (t == kNever) ref.erase(slot);
    else ref[slot] = t;
    ASSERT_EQ(h.size(), ref.size()) << "step " << step;
    ASSERT_EQ(h.deadline(slot), t);
    if (ref.empty()) continue;
    auto best = ref.begin();
    for (auto it = ref.begin(); it != ref.end(); ++it)
      if (it->second < best->second) best = it;  // ties: lowest slot (map order)
    ASSERT_EQ(h.top(), best->first) << "step " << step;
    ASSERT_EQ(h.top_time(), best->second);
  }
}

TEST(DeadlineHeap, MatchesABruteForceMinimumUnderRandomUpdates) { check_deadline_heap(0); }
TEST(DeadlineHeap, MatchesABruteForceMinimumInARotatingFleet) { check_deadline_heap(1); }
TEST(DeadlineHeap, MatchesABruteForceMinimumInAMixedFleet) { check_deadline_heap(2); }
TEST(DeadlineHeap, MatchesABruteForceMinimumBehindANodeThatNeverRuns) { check_deadline_heap(3); }

TEST_F(LoopTest, BootUpFramesAtPowerOnAndNothingBeforeTheFirstDeadline) {
  NodeRef a = add(1), b = add(2);
  core.power_on(a, 0);
  core.power_on(b, 0);
  auto got = frames(tx);
  ASSERT_EQ(got.size(), 2u) << dump(got);
  EXPECT_EQ(got[0], std::make_pair(TimeUs(0), F(0x701, {0x00})));
  EXPECT_EQ(got[1], std::make_pair(TimeUs(0), F(0x702, {0x00})));
  // generic-404: heartbeat 1000 ms, TPDOs only in OPERATIONAL.
  EXPECT_EQ(core.next_deadline(), ms(1000));
  core.run_until(ms(999));
  EXPECT_TRUE(frames(tx).empty());
}

TEST_F(LoopTest, DeadlinesOfSeveralNodesRunInTimeOrder) {
  NodeRef a = add(1), b = add(2), c = add(3);
  for (NodeRef r : {a, b, c}) core.power_on(r, 0);
  write_u16(1, 0x1017, 0, 30, 0);
  write_u16(2, 0x1017, 0, 20, 0);
  write_u16(3, 0x1017, 0, 50, 0);
  tx.take();
  core.run_until(ms(100));
  auto got = frames(tx);
  std::vector<std::pair<TimeUs, CanFrame>> want = {
      {ms(20), F(0x702, {0x7F})},  {ms(30), F(0x701, {0x7F})},  {ms(40), F(0x702, {0x7F})}, {ms(50), F(0x703, {0x7F})},
      {ms(60), F(0x701, {0x7F})},  {ms(60), F(0x702, {0x7F})},  {ms(80), F(0x702, {0x7F})}, {ms(90), F(0x701, {0x7F})},
      {ms(100), F(0x702, {0x7F})}, {ms(100), F(0x703, {0x7F})},
  };
  EXPECT_EQ(got, want) << dump(got);
}

TEST_F(LoopTest, LateWakeUpsDoNotDriftThePeriod) {
  NodeRef a = add(1);
  core.power_on(a, 0);
  write_u16(1, 0x1017, 0, 100, 0);
  tx.take();
  for (int k = 1; k <= 5; ++k) {
    ASSERT_EQ(core.next_deadline(), ms(100) * k);
    core.run_due(core.next_deadline() + 700);  // the timer fired 0.7 ms late
  }
  auto got = frames(tx);
  ASSERT_EQ(got.size(), 5u) << dump(got);
  for (int k = 1; k <= 5; ++k) EXPECT_EQ(got[k - 1].first, ms(100) * k + 700);
  EXPECT_EQ(core.next_deadline(), ms(600));
}

TEST_F(LoopTest, LocalFramesReachTheOtherNodesButNotTheSender) {
  // Node 1 plays master: NMT "start all nodes" at 5 ms, then an SDO upload of
  // 0x1000 from node 2 at 6 ms. Node 2 answers within the same step.
  auto app = std::make_unique<ScriptApp>();
  app->script = {{ms(5), F(0x000, {0x01, 0x00})}, {ms(6), F(0x602, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0})}};
  NodeRef a = add(1, std::move(app)), b = add(2);
  core.power_on(a, 0);
  core.power_on(b, 0);
  tx.take();
  core.run_until(ms(5));
  EXPECT_EQ(core.node(b).state(), NmtState::kOperational);
  EXPECT_EQ(core.node(a).state(), NmtState::kPreOperational) << "the sender heard its own NMT command";
  core.run_until(ms(6));
  auto got = frames(tx);
  ASSERT_GE(got.size(), 3u) << dump(got);
  EXPECT_EQ(got[0], std::make_pair(ms(5), F(0x000, {0x01, 0x00})));
  // Entering OPERATIONAL, node 2's event-driven TPDO1 may go out at 5 ms; the
  // SDO exchange is the last pair either way.
  EXPECT_EQ(got[got.size() - 2], std::make_pair(ms(6), F(0x602, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0})));
  EXPECT_EQ(got[got.size() - 1], std::make_pair(ms(6), F(0x582, {0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00})));
  // The NMT command and the SDO request; nobody here listens to the boot-ups
  // or to the SDO response, so they are not queued for local delivery.
  EXPECT_EQ(core.stats().local_deliveries, 2u) << dump(got);
}

TEST_F(LoopTest, LocalDeliveryIsQueuedNeverReentrant) {
  PingPong p;
  auto first = std::make_unique<SyncEcho>(p);
  first->script = {{ms(1), F(0x080, {})}};
  NodeRef a = add(1, std::move(first)), b = add(2, std::make_unique<SyncEcho>(p));
  core.power_on(a, 0);
  core.power_on(b, 0);
  tx.take();
  core.run_until(ms(1));
  auto got = frames(tx);
  // The SYNC from node 1, then six answers bouncing between the two nodes,
  // each delivered after the previous handler returned.
  ASSERT_EQ(got.size(), 7u) << dump(got);
  for (auto& [t, f] : got) EXPECT_EQ(std::make_pair(t, f), std::make_pair(ms(1), F(0x080, {})));
  EXPECT_EQ(p.max_depth, 1);
  EXPECT_EQ(p.budget, -1);
}

TEST_F(LoopTest, FramesFromTheWireReachEveryListenerOnce) {
  NodeRef a = add(1), b = add(2), c = add(3);
  for (NodeRef r : {a, b, c}) core.power_on(r, 0);
  tx.take();
  core.receive(bus, F(0x000, {0x01, 0x00}), ms(1));  // start all
  for (NodeRef r : {a, b, c}) EXPECT_EQ(core.node(r).state(), NmtState::kOperational);
  core.receive(bus, F(0x000, {0x02, 0x02}), ms(2));  // stop node 2 only
  EXPECT_EQ(core.node(a).state(), NmtState::kOperational);
  EXPECT_EQ(core.node(b).state(), NmtState::kStopped);
  EXPECT_EQ(core.stats().frames_in, 2u);
}

TEST_F(LoopTest, RemovedNodeFallsSilentAndItsSlotIsReused) {
  NodeRef a = add(1), b = add(2);
  core.power_on(a, 0);
  core.power_on(b, 0);
  tx.take();
  core.remove_node(a);
  EXPECT_EQ(core.node_count(), 1u);
  core.receive(bus, F(0x601, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), ms(1));
  EXPECT_TRUE(frames(tx).empty());
  core.run_until(ms(1000));
  auto got = frames(tx);
  ASSERT_EQ(got.size(), 1u) << dump(got);
  EXPECT_EQ(got[0].second, F(0x702, {0x7F}));
  NodeRef c = add(5);
  EXPECT_EQ(c, a);
  core.power_on(c, ms(1000));
  EXPECT_EQ(frames(tx), (std::vector<std::pair<TimeUs, CanFrame>>{{ms(1000), F(0x705, {0x00})}}));
}

TEST_F(LoopTest, NodesOnAnotherBusDoNotHearIt) {
  MemoryTransport tx2(&core.now());
  BusId bus2 = core.add_bus("vcan1", tx2, 3);
  NodeRef a = add(1);
  NodeRef b = core.add_node(bus2, config::node_setup(profile, 1));  // same node-ID, other bus: no collision
  core.power_on(a, 0);
  core.power_on(b, 0);
  core.receive(bus, F(0x000, {0x01, 0x00}), ms(1));
  EXPECT_EQ(core.node(a).state(), NmtState::kOperational);
  EXPECT_EQ(core.node(b).state(), NmtState::kPreOperational);
  EXPECT_EQ(frames(tx2), (std::vector<std::pair<TimeUs, CanFrame>>{{0, F(0x701, {0x00})}}));
}

TEST_F(LoopTest, BusBitRateMismatchSilencesTheNode) {
  NodeRef a = add(1);
  core.set_bus_bit_rate(bus, 4);  // bus at 125 kbit/s, node at 250
  core.power_on(a, 0);
  EXPECT_TRUE(frames(tx).empty());
  core.set_bus_bit_rate(bus, 3);
  core.run_until(ms(1000));
  EXPECT_EQ(frames(tx), (std::vector<std::pair<TimeUs, CanFrame>>{{ms(1000), F(0x701, {0x7F})}}));
}

}  // namespace
}  // namespace cansim::io
