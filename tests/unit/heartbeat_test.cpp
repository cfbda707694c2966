// Heartbeat producer 0x1017 and consumer 0x1016 (CiA 301 §7.2.8.3.2).
#include "nmt_support.hpp"

namespace cansim::nmt_test {
namespace {

using Heartbeat = Harness;

TEST_F(Heartbeat, FirstBeatOnePeriodAfterBootUpAndNoDriftOver100Periods) {
  SimNode& n = add(5);
  n->power_on(0);  // profile default 0x1017 = 0
  ASSERT_EQ(wr16(n, 0x1017, 0, 0), SdoAbort::kNone);
  take();
  nmt(0x81, 5);  // boot again with a stored period of 100 ms
  ASSERT_EQ(wr16(n, 0x1017, 0, 100), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 1, StoreRestore::kSave), SdoAbort::kNone);
  bus.run_until(ms(7));
  nmt(0x81, 5);
  EXPECT_EQ(take(), S({{0, F(0x705, {0x00})}, {ms(7), F(0x705, {0x00})}}));
  // Advance in uneven steps: beats stay on the absolute grid 7 ms + k·100 ms.
  TimeUs t = ms(7);
  while (t < ms(7) + ms(100) * 100) {
    t += 33'333;
    bus.run_until(t);
  }
  auto log = bus.take();
  ASSERT_EQ(log.size(), 100u);
  for (std::size_t k = 0; k < log.size(); ++k) {
    EXPECT_EQ(log[k].time, ms(7) + ms(100) * TimeUs(k + 1)) << k;
    EXPECT_EQ(log[k].frame, F(0x705, {0x7F}));
  }
}

// Processing late (a busy loop) sends one beat and keeps the t0 + k·period
// grid instead of restarting the period from the late time.
TEST_F(Heartbeat, LateProcessingKeepsTheGrid) {
  SimNode& n = add(5);
  n->power_on(0);
  ASSERT_EQ(wr16(n, 0x1017, 0, 100), SdoAbort::kNone);
  take();
  EXPECT_EQ(n->next_deadline(), ms(100));
  n->advance(ms(130));
  EXPECT_EQ(n->heartbeat().next_deadline(), ms(200));
  n->advance(ms(455));
  EXPECT_EQ(n->heartbeat().next_deadline(), ms(500));
  EXPECT_EQ(bus.take().size(), 2u);
}

TEST_F(Heartbeat, StateByteFollowsNmtState) {
  SimNode& n = add(5, "{}", "");
  n->power_on(0);
  ASSERT_EQ(wr16(n, 0x1017, 0, 10), SdoAbort::kNone);
  take();
  bus.run_until(ms(10));
  nmt(0x01, 5);
  bus.run_until(ms(20));
  nmt(0x02, 5);
  bus.run_until(ms(30));
  nmt(0x80, 5);
  bus.run_until(ms(40));
  EXPECT_EQ(take(), S({{ms(10), F(0x705, {0x7F})},
                       {ms(20), F(0x705, {0x05})},
                       {ms(30), F(0x705, {0x04})},
                       {ms(40), F(0x705, {0x7F})}}));
}

TEST_F(Heartbeat, WriteRestartsThePeriodAndZeroStopsIt) {
  SimNode& n = add(5);
  bus.power_on_all();
  ASSERT_EQ(wr16(n, 0x1017, 0, 100), SdoAbort::kNone);
  bus.run_until(ms(150));
  ASSERT_EQ(wr16(n, 0x1017, 0, 40), SdoAbort::kNone);  // at 150 ms
  bus.run_until(ms(235));
  ASSERT_EQ(wr16(n, 0x1017, 0, 0), SdoAbort::kNone);
  bus.run_until(ms(1000));
  EXPECT_EQ(take(), S({{0, F(0x705, {0x00})},
                       {ms(100), F(0x705, {0x7F})},
                       {ms(190), F(0x705, {0x7F})},
                       {ms(230), F(0x705, {0x7F})}}));
}

TEST_F(Heartbeat, NoHeartbeatBeforeBootUp) {
  SimNode& n = add(5, "{boot_up_delay_ms: 30}");
  n->power_on(0);
  ASSERT_EQ(wr16(n, 0x1017, 0, 10), SdoAbort::kNone);
  bus.run_until(ms(45));
  EXPECT_EQ(take(), S({{ms(30), F(0x705, {0x00})}, {ms(40), F(0x705, {0x7F})}}));
}

// ---------------------------------------------------------------- consumer

class Consumer : public Harness {
 protected:
  SimNode& start(const std::string& extra = error_behaviour(0)) {
    SimNode& n = add(5, "{}", extra);
    bus.power_on_all();
    take();
    return n;
  }
  void hb(std::uint8_t id, std::uint8_t state) { inject(F(0x700u + id, {state})); }
};

TEST_F(Consumer, NoMonitoringBeforeTheFirstHeartbeat) {
  SimNode& n = start();
  ASSERT_EQ(wr32(n, 0x1016, 1, 0x00200064), SdoAbort::kNone);  // node 0x20, 100 ms
  bus.run_until(ms(1000));
  hb(0x20, 0x00);  // boot-up does not start monitoring
  bus.run_until(ms(2000));
  EXPECT_EQ(take(), "");
}

TEST_F(Consumer, TimeoutSendsEmcyAtTheExactTimeAndRecoveryClearsIt) {
  SimNode& n = start();
  nmt(0x01, 5);
  ASSERT_EQ(wr32(n, 0x1016, 2, 0x00200064), SdoAbort::kNone);
  bus.run_until(ms(10));
  hb(0x20, 0x05);
  bus.run_until(ms(60));
  hb(0x20, 0x05);  // restarts the 100 ms
  bus.run_until(ms(160) - 1);
  EXPECT_EQ(take(), "");
  bus.run_until(ms(160));
  EXPECT_EQ(take(), S({{ms(160), F(0x85, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0})}}));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);  // 0x1029:01 = 0
  EXPECT_EQ(rd(n, 0x1001, 0), 0x11u);
  EXPECT_EQ(rd(n, 0x1003, 1), 0x8130u);
  bus.run_until(ms(500));
  EXPECT_EQ(take(), "");  // one EMCY per failure
  hb(0x20, 0x7F);
  EXPECT_EQ(take(), S({{ms(500), F(0x85, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0})}}));
  EXPECT_EQ(rd(n, 0x1001, 0), 0u);
  bus.run_until(ms(600));
  EXPECT_EQ(take(), S({{ms(600), F(0x85, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0})}}));
}

TEST_F(Consumer, BootUpReArmsAfterTimeout) {
  SimNode& n = start();
  ASSERT_EQ(wr32(n, 0x1016, 1, 0x00200032), SdoAbort::kNone);  // 50 ms
  hb(0x20, 0x7F);
  bus.run_until(ms(50));
  take();
  hb(0x20, 0x00);  // the producer rebooted: clears, waits for its next beat
  bus.run_until(ms(500));
  EXPECT_EQ(take(), S({{ms(50), F(0x85, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0})}}));
}

TEST_F(Consumer, ErrorBehaviourReactions) {
  for (int behaviour : {0, 1, 2}) {
    SimBus local;
    config::Profile p = config::parse_profile(profile_text("{}", error_behaviour(behaviour)));
    SimNode& n = local.add(p, 5);
    local.power_on_all();
    local.inject(F(0x000, {0x01, 0x05}));
    std::uint8_t v[4] = {0x64, 0x00, 0x20, 0x00};
    ASSERT_EQ(n->write(0x1016, 1, v, 0), SdoAbort::kNone);
    local.inject(F(0x720, {0x05}));
    local.run_until(ms(100));
    NmtState expected = behaviour == 0   ? NmtState::kPreOperational
                        : behaviour == 1 ? NmtState::kOperational
                                         : NmtState::kStopped;
    EXPECT_EQ(n->state(), expected) << behaviour;
  }
}

TEST_F(Consumer, PreOperationalStaysWithBehaviourZero) {
  SimNode& n = start();
  ASSERT_EQ(wr32(n, 0x1016, 1, 0x00200064), SdoAbort::kNone);
  hb(0x20, 0x05);
  bus.run_until(ms(100));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  nmt(0x02, 5);  // stopped: EMCY not sent, but the reaction still applies
  hb(0x20, 0x05);
  bus.run_until(ms(300));
  EXPECT_EQ(take(), S({{ms(100), F(0x85, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0})}}));
}

TEST_F(Consumer, ErrorBehaviourValues) {
  SimNode& n = start();
  EXPECT_EQ(wr8(n, 0x1029, 1, 3), SdoAbort::kInvalidValue);
  EXPECT_EQ(wr8(n, 0x1029, 1, 0x7F), SdoAbort::kInvalidValue);
  EXPECT_EQ(wr8(n, 0x1029, 1, 0x80), SdoAbort::kNone);  // manufacturer-specific
  EXPECT_EQ(wr8(n, 0x1029, 1, 2), SdoAbort::kNone);
  EXPECT_EQ(rd(n, 0x1029, 1), 2u);
}

TEST_F(Consumer, NoErrorBehaviourObjectUsesTheOption) {
  SimNode& n = add(5, "{comm_error_reaction_without_1029: 2}");
  bus.power_on_all();
  ASSERT_EQ(wr32(n, 0x1016, 1, 0x00200064), SdoAbort::kNone);
  inject(F(0x720, {0x05}));
  bus.run_until(ms(100));
  EXPECT_EQ(n->state(), NmtState::kStopped);
}

TEST_F(Consumer, VendorEmcyCodeOption) {
  SimNode& n = add(5, "{heartbeat_consumer_emcy: 0x8100}");
  bus.power_on_all();
  take();
  ASSERT_EQ(wr32(n, 0x1016, 1, 0x00200064), SdoAbort::kNone);
  inject(F(0x720, {0x05}));
  bus.run_until(ms(100));
  EXPECT_EQ(take(), S({{ms(100), F(0x85, {0x00, 0x81, 0x11, 0, 0, 0, 0, 0})}}));
}

TEST_F(Consumer, DuplicateNodeIdAndInvalidEntries) {
  SimNode& n = start();
  ASSERT_EQ(wr32(n, 0x1016, 1, 0x00200064), SdoAbort::kNone);
  EXPECT_EQ(wr32(n, 0x1016, 2, 0x002000C8), SdoAbort::kParamIncompatible);
  EXPECT_EQ(rd(n, 0x1016, 2), 0u);
  EXPECT_EQ(wr32(n, 0x1016, 2, 0x00200000), SdoAbort::kNone);  // time 0: unused, allowed
  EXPECT_EQ(wr32(n, 0x1016, 1, 0x002000C8), SdoAbort::kNone);  // rewriting the same entry
  EXPECT_EQ(wr32(n, 0x1016, 2, 0x00210064), SdoAbort::kNone);
  EXPECT_EQ(wr32(n, 0x1016, 1, 0x01200064), SdoAbort::kInvalidValue);  // reserved bits 31-24
  EXPECT_EQ(wr32(n, 0x1016, 1, 0x00800064), SdoAbort::kInvalidValue);  // node-ID 128
  EXPECT_EQ(wr16(n, 0x1016, 1, 0x0064), SdoAbort::kLengthTooLow);
  EXPECT_EQ(wr8(n, 0x1016, 0, 3), SdoAbort::kReadOnly);
}

TEST_F(Consumer, RewritingAnEntryStopsItsMonitoring) {
  SimNode& n = start();
  ASSERT_EQ(wr32(n, 0x1016, 1, 0x00200064), SdoAbort::kNone);
  hb(0x20, 0x05);
  bus.run_until(ms(50));
  ASSERT_EQ(wr32(n, 0x1016, 1, 0), SdoAbort::kNone);
  bus.run_until(ms(1000));
  EXPECT_EQ(take(), "");
}

TEST_F(Consumer, GenericProfileHasFourEntries) {
  SimNode& n = add_profile(test::load_repo_profile("generic-404"), 0x10);
  bus.power_on_all();
  take();
  ASSERT_EQ(wr32(n, 0x1016, 4, 0x00030064), SdoAbort::kNone);
  inject(F(0x703, {0x7F}));
  bus.run_until(ms(100));
  auto log = bus.take();
  ASSERT_FALSE(log.empty());
  EXPECT_EQ(log[0].time, ms(100));
  EXPECT_EQ(log[0].frame, F(0x90, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0}));
}

}  // namespace
}  // namespace cansim::nmt_test
