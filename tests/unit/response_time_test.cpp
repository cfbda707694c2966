// Response times (docs/faults.md "Response times"): the SDO turnaround, the
// synchronous TPDOs after SYNC and the boot-up, each with its seeded jitter,
// frame by frame on the fake clock.
#include <gtest/gtest.h>

#include <set>
#include <vector>

#include "daemon/daemon.hpp"
#include "pdo_fixture.hpp"
#include "sdo_support.hpp"

namespace cansim::test {
namespace {

const CanFrame kUpload1000 = F(kSdoRx, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});
const CanFrame kUpload1001 = F(kSdoRx, {0x40, 0x01, 0x10, 0x00, 0, 0, 0, 0});
constexpr std::uint32_t kBootUp = 0x710;  // generic-404's node-ID 0x10

// A generic-404 node with `options`, booted and pre-operational, its log cleared.
class Responder {
 public:
  explicit Responder(const std::string& options, std::uint64_t seed = 1)
      : sim_(bus_.add(generic_with_options(options), 0x10, nullptr, std::nullopt, seed)) {
    bus_.power_on_all();
    bus_.run_for(ms(1));
    bus_.take();
  }
  SimBus& bus() { return bus_; }
  Node& node() { return sim_.node(); }
  // The request goes at `at`; the SDO answers until `until`.
  std::vector<Sent> ask(const CanFrame& request, TimeUs at, TimeUs until) {
    bus_.run_until(at);
    bus_.inject(request);
    bus_.run_until(until);
    return sdo_answers();
  }
  std::vector<Sent> sdo_answers() {
    std::vector<Sent> out;
    for (const Sent& s : bus_.take())
      if (s.frame.id == kSdoTx) out.push_back(s);
    return out;
  }
  // The turnaround of `n` uploads, 10 ms apart (each answered before the next).
  std::vector<TimeUs> turnarounds(int n) {
    std::vector<TimeUs> out;
    for (int i = 0; i < n; ++i) {
      const TimeUs at = ms(10) * (i + 1);
      const std::vector<Sent> a = ask(kUpload1000, at, at + ms(9));
      if (a.size() != 1) return {};
      out.push_back(a[0].time - at);
    }
    return out;
  }

 private:
  SimBus bus_;
  SimNode& sim_;
};

TEST(ResponseTime, WithoutTheOptionsTheAnswerLeavesAtTheRequest) {
  Responder r("");
  const auto a = r.ask(kUpload1000, ms(10), ms(20));
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0].time, ms(10));
}

TEST(ResponseTime, SdoAnswerLeavesExactlyTheTurnaroundAfterTheRequest) {
  Responder r("sdo_turnaround_us: 2500");
  r.bus().run_until(ms(10));
  r.bus().inject(kUpload1000);
  r.bus().run_until(ms(10) + 2499);
  EXPECT_TRUE(r.sdo_answers().empty());
  r.bus().run_until(ms(10) + 2500);
  const auto a = r.sdo_answers();
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0].time, ms(10) + 2500);
  const auto at_once = Responder("").ask(kUpload1000, ms(10), ms(20));  // the same answer, later
  ASSERT_EQ(at_once.size(), 1u);
  EXPECT_EQ(a[0].frame, at_once[0].frame);
}

TEST(ResponseTime, SdoJitterStaysInItsRangeAndFollowsTheSeed) {
  const std::string options = "sdo_turnaround_us: 1000, sdo_turnaround_jitter_us: 500";
  const std::vector<TimeUs> first = Responder(options, 7).turnarounds(20);
  ASSERT_EQ(first.size(), 20u);
  for (TimeUs t : first) {
    EXPECT_GE(t, 1000);
    EXPECT_LE(t, 1500);
  }
  EXPECT_GT(std::set<TimeUs>(first.begin(), first.end()).size(), 5u);  // it varies
  EXPECT_EQ(Responder(options, 7).turnarounds(20), first);             // the same seed: the same times
  EXPECT_NE(Responder(options, 8).turnarounds(20), first);             // another seed: others
}

// One request at a time, in order: the second starts its turnaround when the
// first answer left.
TEST(ResponseTime, BackToBackRequestsAreAnsweredInOrderOneTurnaroundApart) {
  Responder r("sdo_turnaround_us: 2000");
  r.bus().run_until(ms(10));
  r.bus().inject(kUpload1000);
  r.bus().run_until(ms(10) + 500);
  r.bus().inject(kUpload1001);
  r.bus().run_until(ms(20));
  const auto a = r.sdo_answers();
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0].time, ms(10) + 2000);
  EXPECT_EQ(a[0].frame.data[1], 0x00);  // 0x1000 first
  EXPECT_EQ(a[1].time, ms(10) + 4000);
  EXPECT_EQ(a[1].frame.data[1], 0x01);
}

// slow_sdo's delay comes on top of the turnaround.
TEST(ResponseTime, SlowSdoAddsItsDelayToTheTurnaround) {
  Responder r("sdo_turnaround_us: 2000");
  r.node().sdo().set_response_delay(ms(300));
  const auto a = r.ask(kUpload1000, ms(10), ms(400));
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0].time, ms(10) + 2000 + ms(300));
}

// The segments of a segmented upload: each its turnaround after its request;
// the protocol timeout counts from the answer's departure.
TEST(ResponseTime, SegmentedUploadAnswersEachSegmentAfterTheTurnaround) {
  Responder r("sdo_turnaround_us: 3000, sdo_timeout_ms: 100");
  auto init = r.ask(F(kSdoRx, {0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}), ms(10), ms(20));
  ASSERT_EQ(init.size(), 1u);
  EXPECT_EQ(init[0].time, ms(10) + 3000);
  EXPECT_EQ(init[0].frame.data[0], 0x41);
  auto seg = r.ask(F(kSdoRx, {0x60, 0, 0, 0, 0, 0, 0, 0}), ms(20), ms(30));
  ASSERT_EQ(seg.size(), 1u);
  EXPECT_EQ(seg[0].time, ms(20) + 3000);
  EXPECT_EQ(seg[0].frame.data[1], 'c');
  // No further request: the timeout abort 100 ms after the segment left.
  r.bus().run_until(ms(23) + ms(100) - 1);
  EXPECT_TRUE(r.sdo_answers().empty());
  r.bus().run_until(ms(23) + ms(100));
  const auto abort = r.sdo_answers();
  ASSERT_EQ(abort.size(), 1u);
  EXPECT_EQ(abort[0].frame.data[0], 0x80);
}

TEST(ResponseTime, PendingSdoAnswerDiesWithAReset) {
  Responder r("sdo_turnaround_us: 5000");
  r.bus().run_until(ms(10));
  r.bus().inject(kUpload1000);
  r.bus().run_until(ms(12));
  r.bus().inject(F(0x000, {0x82, 0x10}));  // reset communication
  r.bus().run_until(ms(30));
  EXPECT_TRUE(r.sdo_answers().empty());
}

TEST(ResponseTime, PendingSdoAnswerIsNotSentInStopped) {
  Responder r("sdo_turnaround_us: 5000");
  r.bus().run_until(ms(10));
  r.bus().inject(kUpload1000);
  r.bus().run_until(ms(12));
  r.bus().inject(F(0x000, {0x02, 0x10}));  // stop
  r.bus().run_until(ms(30));
  EXPECT_TRUE(r.sdo_answers().empty());
}

// ---- synchronous TPDOs (pdo_fixture: TPDO2 0x285 type 1 maps 0x2003)

using pdo_test::PdoBus;

TEST(ResponseTime, SyncTpdoLeavesTheDelayAfterSyncWithTheDataSampledAtSync) {
  PdoBus b("{sync_tpdo_delay_us: 700}");
  b.start();
  b.bus().run_until(ms(20));
  b.sync();
  b.set(0x2003, 0, 0x99);  // after the SYNC: not in this PDO
  b.bus().run_until(ms(20) + 699);
  EXPECT_TRUE(b.sent(0x285).empty());
  b.bus().run_until(ms(20) + 700);
  const auto f = b.sent(0x285);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].time, ms(20) + 700);
  EXPECT_EQ(f[0].frame, F(0x285, {0x88}));
}

TEST(ResponseTime, SyncTpdoJitterStaysInItsRangeAndFollowsTheSeed) {
  auto delays = [](std::uint64_t seed) {
    PdoBus b("{sync_tpdo_delay_us: 400, sync_tpdo_jitter_us: 300}", nullptr, seed);
    b.start();
    std::vector<TimeUs> out;
    for (int i = 1; i <= 20; ++i) {
      b.bus().run_until(ms(10) * i);
      b.sync();
      b.bus().run_until(ms(10) * i + ms(5));
      const auto f = b.sent(0x285);
      if (f.size() != 1) return std::vector<TimeUs>{};
      out.push_back(f[0].time - ms(10) * i);
    }
    return out;
  };
  const std::vector<TimeUs> first = delays(3);
  ASSERT_EQ(first.size(), 20u);
  for (TimeUs t : first) {
    EXPECT_GE(t, 400);
    EXPECT_LE(t, 700);
  }
  EXPECT_GT(std::set<TimeUs>(first.begin(), first.end()).size(), 5u);
  EXPECT_EQ(delays(3), first);
  EXPECT_NE(delays(4), first);
}

// Type 0 (acyclic synchronous) is not delayed: the delay is the cyclic ones'.
TEST(ResponseTime, AcyclicSyncTpdoIsNotDelayed) {
  PdoBus b("{sync_tpdo_delay_us: 700}");
  ASSERT_EQ(b.write(0x1800, 2, 0), SdoAbort::kNone);
  b.start();
  b.node().pdo().raise_event(1);
  b.bus().run_until(ms(20));
  b.sync();
  const auto f = b.sent(0x185);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].time, ms(20));
}

// A delay beyond the synchronous window 0x1007: the PDO is not sent (CiA 301 §7.2.5).
TEST(ResponseTime, SyncTpdoPastTheSynchronousWindowIsNotSent) {
  PdoBus b("{sync_tpdo_delay_us: 700}");
  ASSERT_EQ(b.write(0x1007, 0, 500), SdoAbort::kNone);
  b.start();
  b.bus().run_until(ms(20));
  b.sync();
  b.bus().run_until(ms(30));
  EXPECT_TRUE(b.sent(0x285).empty());
}

TEST(ResponseTime, DelayedSyncTpdoIsWithdrawnWhenTheNodeLeavesOperational) {
  PdoBus b("{sync_tpdo_delay_us: 700}");
  b.start();
  b.bus().run_until(ms(20));
  b.sync();
  b.bus().run_until(ms(20) + 300);
  b.nmt(0x80);  // pre-operational
  b.bus().run_until(ms(30));
  EXPECT_TRUE(b.sent(0x285).empty());
}

// ---- boot-up

// The time of the boot-up frame after power-on at 0.
TimeUs boot_up_time(const std::string& options, std::uint64_t seed) {
  SimBus bus;
  bus.add(generic_with_options(options), 0x10, nullptr, std::nullopt, seed);
  bus.power_on_all();
  bus.run_until(ms(1000));
  for (const Sent& s : bus.take())
    if (s.frame == F(kBootUp, {0x00})) return s.time;
  return kNever;
}

TEST(ResponseTime, BootUpLeavesTheDelayAfterPowerOn) { EXPECT_EQ(boot_up_time("boot_up_delay_ms: 100", 1), ms(100)); }

TEST(ResponseTime, BootUpJitterStaysInItsRangeAndFollowsTheSeed) {
  const std::string options = "boot_up_delay_ms: 100, boot_up_jitter_ms: 50";
  std::set<TimeUs> seen;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const TimeUs t = boot_up_time(options, seed);
    EXPECT_GE(t, ms(100));
    EXPECT_LE(t, ms(150));
    EXPECT_EQ(boot_up_time(options, seed), t);
    seen.insert(t);
  }
  EXPECT_GT(seen.size(), 5u);  // another seed: another time
}

// Each reset draws its own jitter.
TEST(ResponseTime, EveryResetDrawsItsBootUpJitter) {
  Responder r("boot_up_delay_ms: 100, boot_up_jitter_ms: 50");
  r.bus().run_until(ms(200));
  std::set<TimeUs> delays;
  for (int i = 1; i <= 8; ++i) {
    const TimeUs at = ms(200) * i;
    r.bus().run_until(at);
    r.bus().take();
    r.bus().inject(F(0x000, {0x81, 0x10}));  // reset node
    r.bus().run_until(at + ms(190));
    for (const Sent& s : r.bus().take())
      if (s.frame == F(kBootUp, {0x00})) delays.insert(s.time - at);
  }
  ASSERT_FALSE(delays.empty());
  EXPECT_GE(*delays.begin(), ms(100));
  EXPECT_LE(*delays.rbegin(), ms(150));
  EXPECT_GT(delays.size(), 3u);
}

// Until its boot-up the node is deaf: SDO, NMT and SYNC before it change nothing.
TEST(ResponseTime, RequestsWhileBootingAreIgnored) {
  SimBus bus;
  SimNode& n = bus.add(generic_with_options("boot_up_delay_ms: 100, sdo_turnaround_us: 1000"), 0x10);
  bus.power_on_all();
  bus.run_until(ms(50));
  bus.inject(kUpload1000);
  bus.inject(F(0x000, {0x01, 0x00}));  // start all
  bus.inject(F(0x080, {}));            // SYNC
  bus.run_until(ms(99));
  EXPECT_TRUE(bus.take().empty());
  EXPECT_EQ(n->state(), NmtState::kInitialising);
  bus.run_until(ms(100));
  const auto boot = bus.take();
  ASSERT_EQ(boot.size(), 1u);
  EXPECT_EQ(boot[0].frame, F(kBootUp, {0x00}));
  bus.run_until(ms(200));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);  // the start was not heard
  for (const Sent& s : bus.take()) EXPECT_NE(s.frame.id, kSdoTx);
  bus.inject(kUpload1000);  // booted: answered
  bus.run_until(ms(202));
  std::vector<TimeUs> answers;
  for (const Sent& s : bus.take())
    if (s.frame.id == kSdoTx) answers.push_back(s.time);
  EXPECT_EQ(answers, std::vector<TimeUs>{ms(201)});
}

// ---- the seed: the fleet's and the node's

TEST(ResponseTime, TheNodeSeedComesFromTheFleetSeedAndTheNodeKey) {
  config::NodeConfig n;
  n.profile = std::make_shared<config::Profile>(generic_with_options(""));
  n.key = "vcan0/a/0";
  const std::uint64_t a = daemon::node_setup(n, 1).seed;
  EXPECT_EQ(daemon::node_setup(n, 1).seed, a);
  EXPECT_NE(daemon::node_setup(n, 2).seed, a);
  n.key = "vcan0/b/0";
  EXPECT_NE(daemon::node_setup(n, 1).seed, a);
}

}  // namespace
}  // namespace cansim::test
