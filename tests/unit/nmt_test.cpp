// NMT slave (CiA 301 §7.2.8.3.1, §7.3.2): boot-up, commands, gating, reset
// scopes, start-up options, LSS-unconfigured nodes.
#include "nmt_support.hpp"

namespace cansim::nmt_test {
namespace {

using Nmt = Harness;

struct Recorder : Application {
  std::string log;
  void on_reset(Node&, ResetKind k, TimeUs t) override {
    log += "reset" + std::to_string(int(k)) + "@" + std::to_string(t) + " ";
  }
  void on_nmt_state(Node&, NmtState s, TimeUs t) override {
    log += "state" + std::to_string(int(s)) + "@" + std::to_string(t) + " ";
  }
};

TEST_F(Nmt, BootUpAtPowerOnThenPreOperational) {
  SimNode& n = add(5);
  bus.run_until(ms(3));
  bus.power_on_all();
  EXPECT_EQ(take(), S({{ms(3), F(0x705, {0x00})}}));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
}

TEST_F(Nmt, BootUpDelayKeepsInitialisingUntilTheFrame) {
  SimNode& n = add(5, "{boot_up_delay_ms: 150}");
  bus.power_on_all();
  EXPECT_EQ(take(), "");
  EXPECT_EQ(n->state(), NmtState::kInitialising);
  nmt(0x01, 0);  // NMT is ignored while initialising
  bus.run_until(ms(150) - 1);
  EXPECT_EQ(take(), "");
  bus.run_until(ms(150));
  EXPECT_EQ(take(), S({{ms(150), F(0x705, {0x00})}}));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
}

TEST_F(Nmt, CommandsForOwnIdAndBroadcast) {
  SimNode& n = add(5);
  bus.power_on_all();
  take();
  nmt(0x01, 5);
  EXPECT_EQ(n->state(), NmtState::kOperational);
  nmt(0x02, 5);
  EXPECT_EQ(n->state(), NmtState::kStopped);
  nmt(0x80, 5);
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  nmt(0x01, 0);
  EXPECT_EQ(n->state(), NmtState::kOperational);
  nmt(0x02, 0);
  EXPECT_EQ(n->state(), NmtState::kStopped);
  nmt(0x01, 0);
  EXPECT_EQ(n->state(), NmtState::kOperational);
  nmt(0x80, 0);
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  EXPECT_EQ(take(), "");  // state changes are silent
}

TEST_F(Nmt, OtherNodeIdsBadLengthAndUnknownCommandsAreIgnored) {
  SimNode& n = add(5);
  bus.power_on_all();
  take();
  nmt(0x01, 6);
  nmt(0x01, 0x85);
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  inject(F(0x000, {0x01}));
  inject(F(0x000, {0x01, 0x05, 0x00}));
  inject(F(0x000, {0x01, 0x00, 0, 0, 0, 0, 0, 0}));
  inject(CanFrame::remote(0x000, 2));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  nmt(0x03, 5);
  nmt(0x83, 5);
  nmt(0x81, 6);
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  EXPECT_EQ(take(), "");
}

TEST_F(Nmt, ResetNodeAndResetCommunicationSendBootUpAgain) {
  SimNode& n = add(5);
  bus.power_on_all();
  nmt(0x01, 5);
  bus.run_until(ms(10));
  take();
  nmt(0x81, 0);
  EXPECT_EQ(take(), S({{ms(10), F(0x705, {0x00})}}));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  nmt(0x02, 5);
  bus.run_until(ms(20));
  nmt(0x82, 5);
  EXPECT_EQ(take(), S({{ms(20), F(0x705, {0x00})}}));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
}

TEST_F(Nmt, AppSeesResetKindAndStateChanges) {
  Recorder rec;
  add(5, "{}", "", &rec);
  bus.power_on_all();
  bus.run_until(ms(1));
  nmt(0x01, 0);
  nmt(0x82, 5);
  bus.run_until(ms(2));
  nmt(0x81, 5);
  EXPECT_EQ(rec.log,
            "reset0@0 state127@0 state5@1000 state0@1000 reset2@1000 state127@1000 "
            "state0@2000 reset1@2000 state127@2000 ");
}

// Reset communication reloads 0x1000-0x1FFF only; reset node everything;
// both from defaults, then stored values.
TEST_F(Nmt, ResetScopes) {
  SimNode& n = add(5);
  bus.power_on_all();
  ASSERT_EQ(wr32(n, 0x1006, 0, 300), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x2000, 0, 100), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1010, 2, StoreRestore::kSave), SdoAbort::kNone);  // communication only
  ASSERT_EQ(wr32(n, 0x1007, 0, 400), SdoAbort::kNone);
  ASSERT_EQ(wr16(n, 0x2001, 0, 200), SdoAbort::kNone);
  nmt(0x82, 5);
  EXPECT_EQ(rd(n, 0x1006, 0), 300u);  // stored
  EXPECT_EQ(rd(n, 0x1007, 0), 0u);    // default again
  EXPECT_EQ(rd(n, 0x2000, 0), 100u);  // application area untouched
  EXPECT_EQ(rd(n, 0x2001, 0), 200u);
  nmt(0x81, 5);
  EXPECT_EQ(rd(n, 0x1006, 0), 300u);
  EXPECT_EQ(rd(n, 0x2000, 0), 7u);  // not stored: default
  EXPECT_EQ(rd(n, 0x2001, 0), 9u);
}

TEST_F(Nmt, StoppedServesNoSdoPreOperationalDoes) {
  SimNode& n = add(5);
  bus.power_on_all();
  take();
  const CanFrame upload = F(0x605, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});
  nmt(0x02, 5);
  inject(upload);
  EXPECT_EQ(take(), "");
  EXPECT_FALSE(n->allowed(Service::kSdo));
  EXPECT_FALSE(n->allowed(Service::kEmcy));
  EXPECT_FALSE(n->allowed(Service::kSync));
  EXPECT_FALSE(n->allowed(Service::kPdo));
  nmt(0x80, 5);
  inject(upload);
  EXPECT_EQ(take(), S({{0, F(0x585, {0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00})}}));
  EXPECT_TRUE(n->allowed(Service::kSdo));
  EXPECT_FALSE(n->allowed(Service::kPdo));
  nmt(0x01, 5);
  EXPECT_TRUE(n->allowed(Service::kPdo));
}

TEST_F(Nmt, AutoStartAfterDelay) {
  SimNode& n = add(5, "{nmt_auto_start: true, nmt_auto_start_delay_ms: 50}");
  bus.power_on_all();
  EXPECT_EQ(take(), S({{0, F(0x705, {0x00})}}));
  bus.run_until(ms(50) - 1);
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  bus.run_until(ms(50));
  EXPECT_EQ(n->state(), NmtState::kOperational);
  // A stop command before the autonomous start cancels it.
  nmt(0x81, 5);
  nmt(0x02, 5);
  bus.run_until(ms(200));
  EXPECT_EQ(n->state(), NmtState::kStopped);
}

TEST_F(Nmt, StartupObject1F80SelfStartAndStartAll) {
  const char* obj = "  - {index: 0x1F80, type: UNSIGNED32, access: rw, default: %s, persistent: yes}\n";
  char text[160];
  std::snprintf(text, sizeof text, obj, "0x08");
  SimNode& self = add(5, "{}", text);
  std::snprintf(text, sizeof text, obj, "0x02");
  SimNode& all = add(6, "{}", text);
  std::snprintf(text, sizeof text, obj, "0x00");
  SimNode& none = add(7, "{}", text);
  std::snprintf(text, sizeof text, obj, "0x04");
  SimNode& four = add(8, "{}", text);
  bus.power_on_all();
  // Node 6's start-all reaches 7 and 8 (already booted) but not 6 itself;
  // it starts itself as it sends the frame.
  EXPECT_EQ(take(), S({{0, F(0x705, {0x00})},
                       {0, F(0x706, {0x00})},
                       {0, F(0x000, {0x01, 0x00})},
                       {0, F(0x707, {0x00})},
                       {0, F(0x708, {0x00})}}));
  EXPECT_EQ(self->state(), NmtState::kOperational);
  EXPECT_EQ(all->state(), NmtState::kOperational);
  EXPECT_EQ(none->state(), NmtState::kPreOperational);
  EXPECT_EQ(four->state(), NmtState::kPreOperational);
}

TEST_F(Nmt, StartupBitTwoClearReadingAndAllowedValues) {
  const std::string obj = "  - {index: 0x1F80, type: UNSIGNED32, access: rw, default: 0, persistent: yes}\n";
  SimNode& n = add(5,
                   "{nmt_startup_self_start_mask: 0x04, nmt_startup_self_start_if_clear: true, "
                   "nmt_startup_values: '0,4'}",
                   obj);
  bus.power_on_all();
  EXPECT_EQ(n->state(), NmtState::kOperational);  // CiA 302-2: bit 2 = 0 starts
  EXPECT_EQ(wr32(n, 0x1F80, 0, 0x08), SdoAbort::kInvalidValue);
  EXPECT_EQ(wr32(n, 0x1F80, 0, 0x100), SdoAbort::kInvalidValue);
  EXPECT_EQ(wr32(n, 0x1F80, 0, 0x04), SdoAbort::kNone);
  EXPECT_EQ(n->state(), NmtState::kOperational);  // takes effect at the next boot
  nmt(0x82, 5);
  EXPECT_EQ(n->state(), NmtState::kOperational);  // not stored: the default 0 again
  EXPECT_EQ(wr32(n, 0x1F80, 0, 0x04), SdoAbort::kNone);
  EXPECT_EQ(wr32(n, 0x1010, 2, StoreRestore::kSave), SdoAbort::kNone);
  nmt(0x82, 5);
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
}

TEST_F(Nmt, StartAllDelayOption) {
  SimNode& n = add(5, "{nmt_start_all_delay_ms: 250}");
  bus.power_on_all();
  bus.run_until(ms(300));
  EXPECT_EQ(take(), S({{0, F(0x705, {0x00})}, {ms(250), F(0x000, {0x01, 0x00})}}));
  EXPECT_EQ(n->state(), NmtState::kOperational);
}

TEST_F(Nmt, BootPlanEditedByApplication) {
  struct SkipBootUp : Application {
    void on_reset(Node& n, ResetKind k, TimeUs) override {
      if (k == ResetKind::kPowerOn) {
        n.nmt().boot_plan().send_boot_up = false;
        n.nmt().boot_plan().self_start = true;
      }
    }
  } app;
  SimNode& n = add(5, "{}", "", &app);
  bus.power_on_all();
  EXPECT_EQ(take(), "");
  EXPECT_EQ(n->state(), NmtState::kOperational);
  nmt(0x81, 5);
  EXPECT_EQ(take(), S({{0, F(0x705, {0x00})}}));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
}

// CiA 305: a node without node-ID neither boots nor obeys NMT until LSS gives
// it an ID and runs reset communication.
TEST_F(Nmt, UnconfiguredNodeWaitsForLss) {
  SimNode& n = add(0xFF);
  bus.power_on_all();
  bus.run_until(ms(100));
  EXPECT_EQ(take(), "");
  EXPECT_EQ(n->state(), NmtState::kInitialising);
  nmt(0x01, 0);
  nmt(0x82, 0);
  EXPECT_EQ(take(), "");
  EXPECT_EQ(n->state(), NmtState::kInitialising);
  // LSS: configuration state, configure node-ID 9, back to waiting state ->
  // the LSS slave activates the ID with NMT reset communication.
  inject(F(0x7E5, {0x04, 0x01, 0, 0, 0, 0, 0, 0}));
  inject(F(0x7E5, {0x11, 0x09, 0, 0, 0, 0, 0, 0}));
  inject(F(0x7E5, {0x04, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_NE(take().find("100000us 709 [1] 00\n"), std::string::npos);
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  EXPECT_EQ(rd(n, 0x1014, 0), 0x89u);  // $NODEID defaults follow the new ID
}

TEST_F(Nmt, PowerOnUsesStoredLssNodeIdAndBitRate) {
  SimNode& n = add(5);
  bus.power_on_all();
  take();
  ASSERT_TRUE(n->store().save_lss({true, 0x22, 3}));
  n.replace(5);
  n->power_on(now());
  EXPECT_EQ(take(), S({{0, F(0x722, {0x00})}}));
  EXPECT_EQ(n->node_id(), 0x22);
  EXPECT_EQ(n->bit_rate_index(), 3);
  ASSERT_TRUE(n->store().save_lss({true, 0x23, 4}));  // other bit rate: silent on this bus
  n.replace(5);
  n->power_on(now());
  EXPECT_EQ(take(), "");
  EXPECT_EQ(n->bit_rate_index(), 4);
}

}  // namespace
}  // namespace cansim::nmt_test
