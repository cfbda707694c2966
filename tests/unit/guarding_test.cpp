// Node guarding and life guarding, 0x100C / 0x100D (CiA 301 §7.2.8.3.1).
#include "nmt_support.hpp"

namespace cansim::nmt_test {
namespace {

class Guarding : public Harness {
 protected:
  SimNode& start(const std::string& options = "{}", const std::string& extra = error_behaviour(0)) {
    SimNode& n = add(5, options, extra);
    bus.power_on_all();
    take();
    return n;
  }
  void rtr() { inject(CanFrame::remote(0x705, 1)); }
};

TEST_F(Guarding, ToggleAlternatesAndCarriesTheState) {
  SimNode& n = start();
  rtr();
  bus.run_until(ms(10));
  rtr();
  nmt(0x01, 5);
  bus.run_until(ms(20));
  rtr();
  nmt(0x02, 5);
  bus.run_until(ms(30));
  rtr();
  EXPECT_EQ(
      take(),
      S({{0, F(0x705, {0x7F})}, {ms(10), F(0x705, {0xFF})}, {ms(20), F(0x705, {0x05})}, {ms(30), F(0x705, {0x84})}}));
  (void)n;
}

TEST_F(Guarding, ResetCommunicationResetsTheToggle) {
  start();
  rtr();
  nmt(0x82, 5);
  rtr();
  rtr();
  nmt(0x81, 5);
  rtr();
  EXPECT_EQ(take(), S({{0, F(0x705, {0x7F})},
                       {0, F(0x705, {0x00})},
                       {0, F(0x705, {0x7F})},
                       {0, F(0x705, {0xFF})},
                       {0, F(0x705, {0x00})},
                       {0, F(0x705, {0x7F})}}));
}

TEST_F(Guarding, OtherIdsAndDataFramesAreNotGuarding) {
  start();
  inject(CanFrame::remote(0x706, 1));
  inject(F(0x705, {0x00}));
  EXPECT_EQ(take(), "");
}

TEST_F(Guarding, NotAnsweredWhileHeartbeatProducerRuns) {
  SimNode& n = start();
  ASSERT_EQ(wr16(n, 0x1017, 0, 1000), SdoAbort::kNone);
  rtr();
  EXPECT_EQ(take(), "");
  ASSERT_EQ(wr16(n, 0x1017, 0, 0), SdoAbort::kNone);
  rtr();
  EXPECT_EQ(take(), S({{0, F(0x705, {0x7F})}}));
}

TEST_F(Guarding, OptionAnswersAlongsideHeartbeat) {
  SimNode& n = start("{guarding_with_heartbeat: true}");
  ASSERT_EQ(wr16(n, 0x1017, 0, 1000), SdoAbort::kNone);
  rtr();
  EXPECT_EQ(take(), S({{0, F(0x705, {0x7F})}}));
}

TEST_F(Guarding, ProfileWithoutGuardObjectsIgnoresRtr) {
  config::Profile p = config::parse_profile(R"(
name: no-guarding
node_id: 5
objects:
  - {index: 0x1000, type: UNSIGNED32, access: ro, default: 0x00020194}
  - {index: 0x1017, type: UNSIGNED16, access: rw, default: 0}
)");
  add_profile(std::move(p), 5);
  bus.power_on_all();
  take();
  rtr();
  EXPECT_EQ(take(), "");
}

TEST_F(Guarding, LifeGuardingStartsWithFirstRtrAndRaisesEmcyAtLifeTime) {
  SimNode& n = start();
  nmt(0x01, 5);
  ASSERT_EQ(wr16(n, 0x100C, 0, 100), SdoAbort::kNone);
  ASSERT_EQ(wr8(n, 0x100D, 0, 3), SdoAbort::kNone);  // life time 300 ms
  bus.run_until(ms(1000));
  EXPECT_EQ(take(), "");  // not started yet
  rtr();
  bus.run_until(ms(1100));
  rtr();  // restarts: expires at 1400 ms
  bus.run_until(ms(1400) - 1);
  EXPECT_EQ(take(), S({{ms(1000), F(0x705, {0x05})}, {ms(1100), F(0x705, {0x85})}}));
  bus.run_until(ms(1400));
  EXPECT_EQ(take(), S({{ms(1400), F(0x85, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0})}}));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  EXPECT_TRUE(n->guarding().life_guard_failed());
  bus.run_until(ms(2000));
  EXPECT_EQ(take(), "");
  rtr();  // guarding resumes: error reset
  EXPECT_EQ(take(), S({{ms(2000), F(0x705, {0x7F})}, {ms(2000), F(0x85, {0, 0, 0, 0, 0, 0, 0, 0})}}));
  EXPECT_FALSE(n->guarding().life_guard_failed());
}

TEST_F(Guarding, ZeroLifeTimeMeansNoLifeGuarding) {
  SimNode& n = start();
  ASSERT_EQ(wr16(n, 0x100C, 0, 100), SdoAbort::kNone);  // factor stays 0
  rtr();
  bus.run_until(ms(5000));
  EXPECT_EQ(take(), S({{0, F(0x705, {0x7F})}}));
  (void)n;
}

TEST_F(Guarding, LifeGuardReactionStopped) {
  SimNode& n = start("{}", error_behaviour(2));
  ASSERT_EQ(wr16(n, 0x100C, 0, 10), SdoAbort::kNone);
  ASSERT_EQ(wr8(n, 0x100D, 0, 2), SdoAbort::kNone);
  rtr();
  bus.run_until(ms(20));
  EXPECT_EQ(n->state(), NmtState::kStopped);
}

}  // namespace
}  // namespace cansim::nmt_test
