// Error frames of a real CAN controller (linux/can/error.h) through the
// transport's receive path (CanInterface::accept, what read_batch does with
// recvmmsg's frames) to the nodes, as the daemon wires them: each device
// answers with the EMCY and NMT reaction its manual gives.
#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>

#include "io/can_interface.hpp"
#include "io/loop_core.hpp"
#include "support/sim.hpp"

namespace cansim::io {
namespace {

using test::F;

::can_frame error_frame(canid_t flags, std::uint8_t controller = 0, int tx_errors = -1, int rx_errors = -1) {
  ::can_frame f{};
  f.can_id = CAN_ERR_FLAG | flags;
  f.len = CAN_ERR_DLC;
  f.data[1] = controller;
  if (tx_errors >= 0) {
    f.can_id |= CAN_ERR_CNT;
    f.data[6] = std::uint8_t(tx_errors);
    f.data[7] = std::uint8_t(rx_errors);
  }
  return f;
}

::can_frame data_frame(canid_t id, std::uint8_t byte) {
  ::can_frame f{};
  f.can_id = id;
  f.len = 1;
  f.data[0] = byte;
  return f;
}

TEST(ControllerErrors, DecodedAsTheKernelReportsThem) {
  using S = CanState;
  struct Case {
    ::can_frame frame;
    S before, after;
    bool lost;
  };
  const Case cases[] = {
      {error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING), S::kErrorActive, S::kErrorWarning, false},
      {error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_PASSIVE), S::kErrorWarning, S::kErrorPassive, false},
      // Both counters reported: the higher state counts.
      {error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE | CAN_ERR_CRTL_RX_WARNING), S::kErrorActive, S::kErrorPassive,
       false},
      {error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE), S::kErrorPassive, S::kErrorActive, false},
      {error_frame(CAN_ERR_BUSOFF), S::kErrorPassive, S::kBusOff, false},
      {error_frame(CAN_ERR_RESTARTED), S::kBusOff, S::kErrorActive, false},
      {error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_OVERFLOW), S::kErrorWarning, S::kErrorWarning, true},
      {error_frame(CAN_ERR_TX_TIMEOUT), S::kErrorActive, S::kErrorActive, false},
  };
  for (const Case& c : cases) {
    const ControllerReport r = decode_error_frame(c.frame, c.before);
    EXPECT_EQ(r.event.state, c.after) << std::hex << c.frame.can_id;
    EXPECT_EQ(r.event.state_changed, c.before != c.after);
    EXPECT_EQ(r.event.frames_lost, c.lost);
    EXPECT_EQ(r.before, c.before);
  }
  const ControllerReport r =
      decode_error_frame(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE, 128, 3), S::kErrorActive);
  EXPECT_EQ(r.tx_errors, 128);
  EXPECT_EQ(r.rx_errors, 3);
  EXPECT_TRUE(decode_error_frame(error_frame(CAN_ERR_RESTARTED), S::kBusOff).restarted);
  EXPECT_TRUE(decode_error_frame(error_frame(CAN_ERR_TX_TIMEOUT), S::kErrorActive).tx_timeout);
}

TEST(ControllerErrors, ErrorFramesBecomeReportsAndDataFramesStayFrames) {
  CanInterface can("can0");      // never opened: the receive path only
  can.set_has_controller(true);  // as open() finds a real controller
  const ::can_frame in[] = {data_frame(0x181, 1), error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE),
                            data_frame(0x182, 2), error_frame(CAN_ERR_CRTL, 0)};
  CanFrame out[4];
  ASSERT_EQ(can.accept(in, 4, out), 2);
  EXPECT_EQ(out[0], F(0x181, {1}));
  EXPECT_EQ(out[1], F(0x182, {2}));
  EXPECT_EQ(can.controller_state(), CanState::kErrorPassive);
  EXPECT_EQ(can.stats().error_frames, 2u);
  ControllerReport r;
  ASSERT_TRUE(can.take_report(r));  // the passive one; the empty CRTL frame says nothing
  EXPECT_EQ(r.event.state, CanState::kErrorPassive);
  EXPECT_FALSE(can.take_report(r));
}

TEST(ControllerErrors, AFloodOfReportsKeepsTheStateAndTheLosses) {
  CanInterface can("can0");
  can.set_has_controller(true);
  std::vector<::can_frame> in;
  in.push_back(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_OVERFLOW));
  for (std::size_t i = 0; i < CanInterface::kReports + 3; ++i)
    in.push_back(error_frame(CAN_ERR_CRTL, i % 2 ? CAN_ERR_CRTL_TX_WARNING : CAN_ERR_CRTL_ACTIVE));
  std::vector<CanFrame> out(in.size());
  can.accept(in.data(), in.size(), out.data());
  ControllerReport r;
  bool lost = false;
  CanState last = CanState::kErrorActive;
  std::size_t n = 0;
  while (can.take_report(r)) {
    lost |= r.event.frames_lost;
    last = r.event.state;
    ++n;
  }
  EXPECT_EQ(n, CanInterface::kReports);
  EXPECT_TRUE(lost) << "the overflow was folded into a later report";
  EXPECT_EQ(last, can.controller_state());
}

// Folded reports say what changed: the overflow flags travel with the loss
// (it was "lost frames ()"), and a change there and back is no change (it was
// "bus-off (was bus-off)").
TEST(ControllerErrors, MergedReportsSayWhatChanged) {
  CanInterface can("can0");
  can.set_has_controller(true);
  std::vector<::can_frame> in{error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_OVERFLOW), error_frame(CAN_ERR_BUSOFF),
                              error_frame(CAN_ERR_RESTARTED), error_frame(CAN_ERR_BUSOFF)};
  for (std::size_t i = 0; i < CanInterface::kReports; ++i)  // pushes the four above into one
    in.push_back(error_frame(CAN_ERR_CRTL, i % 2 ? CAN_ERR_CRTL_RX_OVERFLOW : CAN_ERR_CRTL_TX_OVERFLOW));
  std::vector<CanFrame> out(in.size());
  can.accept(in.data(), in.size(), out.data());
  ControllerReport r;
  ASSERT_TRUE(can.take_report(r));
  EXPECT_GT(r.merged, 0u);
  EXPECT_TRUE(r.event.frames_lost);
  EXPECT_TRUE(r.tx_overflow || r.rx_overflow);
  EXPECT_EQ(r.event.state_changed, r.event.state != r.before);
  while (can.take_report(r)) {
    EXPECT_TRUE(!r.event.frames_lost || r.rx_overflow || r.tx_overflow);
    EXPECT_FALSE(r.event.state_changed && r.event.state == r.before);
  }
  EXPECT_EQ(can.controller_state(), CanState::kBusOff);
}

// On a virtual bus any local program may write error frames (`cansend vcan0
// 20000040#...` as nobody): they are counted and change nothing; the same
// frame on a real controller still takes it bus-off.
TEST(ControllerErrors, AVirtualBusHasNoControllerState) {
  CanInterface vcan("vcan0");  // never opened: no controller, as open() finds a vcan
  ASSERT_FALSE(vcan.has_controller());
  const ::can_frame in[] = {error_frame(CAN_ERR_BUSOFF), data_frame(0x181, 1),
                            error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE | CAN_ERR_CRTL_RX_OVERFLOW),
                            error_frame(CAN_ERR_RESTARTED | CAN_ERR_TX_TIMEOUT)};
  CanFrame out[4];
  ASSERT_EQ(vcan.accept(in, 4, out), 1);
  EXPECT_EQ(out[0], F(0x181, {1}));
  EXPECT_EQ(vcan.controller_state(), CanState::kErrorActive);
  EXPECT_EQ(vcan.stats().error_frames_ignored, 3u);
  EXPECT_EQ(vcan.stats().error_frames, 0u);
  EXPECT_EQ(vcan.stats().tx_timeouts, 0u);
  ControllerReport r;
  EXPECT_FALSE(vcan.take_report(r));
  CanInterface can("can0");
  can.set_has_controller(true);
  can.accept(in, 1, out);
  EXPECT_EQ(can.controller_state(), CanState::kBusOff);
}

// ---------------------------------------------------------------- the nodes

class NodeReactions : public ::testing::Test {
 protected:
  NodeReactions() : tx(&core.now()) {
    bus = core.add_bus("can0", tx, 3);
    can.set_has_controller(true);
  }
  NodeRef add(const char* profile, std::uint8_t id) {
    profiles.push_back(std::make_unique<config::Profile>(test::load_repo_profile(profile)));
    NodeSetup s = config::node_setup(*profiles.back(), id);
    s.bit_rate_index = 3;
    NodeRef r = core.add_node(bus, s);
    core.power_on(r, 0);
    return r;
  }
  // What the daemon does with a received batch (Daemon::on_can_events).
  void inject(std::initializer_list<::can_frame> frames, TimeUs t) {
    std::vector<::can_frame> in(frames);
    std::vector<CanFrame> out(in.size());
    const int n = can.accept(in.data(), in.size(), out.data());
    for (int i = 0; i < n; ++i) core.receive(bus, out[i], t);
    ControllerReport r;
    while (can.take_report(r)) core.controller_event(bus, r.event, t);
  }
  std::vector<CanFrame> emcys() {
    std::vector<CanFrame> out;
    for (auto& s : tx.take())
      if (s.frame.id >= 0x81 && s.frame.id <= 0xFF) out.push_back(s.frame);
    return out;
  }

  LoopCore core;
  MemoryTransport tx;
  CanInterface can{"can0"};
  BusId bus = 0;
  std::vector<std::unique_ptr<config::Profile>> profiles;
};

TEST_F(NodeReactions, EachDeviceAnswersAsItsManualSays) {
  const NodeRef generic = add("generic-404", 0x10), dps = add("dps", 0x11), p92c = add("p92c", 0x12),
                gems = add("gems9000", 0x13);
  core.run_until(ms(10));
  core.receive(bus, F(0x000, {0x01, 0x00}), ms(10));  // all operational
  core.run_until(ms(20));
  tx.take();

  inject({error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING, 96, 0)}, ms(20));
  EXPECT_TRUE(emcys().empty()) << "CiA 301 has no EMCY for the warning level";

  inject({error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE, 128, 0)}, ms(30));
  // CiA 301 0x8120 (register: generic + communication); DPS Table 24 0x8120 /
  // 0x11; P92C §3.6 0x8100, its only communication code; Gems Fig. 28 0x8120 / 0x88.
  EXPECT_EQ(emcys(), (std::vector<CanFrame>{
                         F(0x90, {0x20, 0x81, 0x11, 0, 0, 0, 0, 0}), F(0x91, {0x20, 0x81, 0x11, 0, 0, 0, 0, 0}),
                         F(0x92, {0x00, 0x81, 0x11, 0, 0, 0, 0, 0}), F(0x93, {0x20, 0x81, 0x88, 0, 0, 0, 0, 0})}));

  inject({error_frame(CAN_ERR_BUSOFF)}, ms(40));
  EXPECT_TRUE(tx.take().empty()) << "off the bus: nothing leaves";
  // The 0x1029:01 reaction: generic-404 0 (pre-operational); DPS, P92C and
  // Gems have no 0x1029 (comm_error_reaction_without_1029: no change).
  EXPECT_EQ(core.node(generic).state(), NmtState::kPreOperational);
  EXPECT_EQ(core.node(dps).state(), NmtState::kOperational);
  core.receive(bus, F(0x611, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), ms(45));
  EXPECT_TRUE(tx.take().empty()) << "nor is anything heard";

  inject({error_frame(CAN_ERR_RESTARTED)}, ms(50));
  // Error active again: the passive error ends (reset EMCY), then the
  // recovery EMCY and its reset. P92C keeps one error at a time (0x1003
  // holds the current situation) and answers each change with the current code.
  const std::vector<CanFrame> after = emcys();
  auto of = [&](std::uint32_t id) {
    std::vector<CanFrame> v;
    for (const CanFrame& f : after)
      if (f.id == id) v.push_back(f);
    return v;
  };
  EXPECT_EQ(of(0x90), (std::vector<CanFrame>{F(0x90, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0}),
                                             F(0x90, {0x40, 0x81, 0x11, 0, 0, 0, 0, 0}),
                                             F(0x90, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0})}));
  EXPECT_EQ(of(0x93), (std::vector<CanFrame>{F(0x93, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0}),
                                             F(0x93, {0x40, 0x81, 0x88, 0, 0, 0, 0, 0}),
                                             F(0x93, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0})}));
  EXPECT_FALSE(of(0x92).empty());
  EXPECT_EQ(of(0x92).front(), F(0x92, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(core.node(p92c).emcy().active(0x8100));
  EXPECT_FALSE(core.node(gems).emcy().active(0x8120));

  inject({error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_OVERFLOW)}, ms(60));
  // CiA 0x8110 then its reset; P92C 0x8100; DPS (Table 24) and Gems (Fig. 28) list no overrun code.
  EXPECT_EQ(emcys(), (std::vector<CanFrame>{
                         F(0x90, {0x10, 0x81, 0x11, 0, 0, 0, 0, 0}), F(0x90, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0}),
                         F(0x92, {0x00, 0x81, 0x11, 0, 0, 0, 0, 0}), F(0x92, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0})}));
}

TEST_F(NodeReactions, TheControllerStateOutlivesAPowerCycleAndMeetsNewNodes) {
  const NodeRef a = add("generic-404", 0x10);
  core.run_until(ms(10));
  inject({error_frame(CAN_ERR_BUSOFF)}, ms(10));
  tx.take();  // the boot-up before
  core.node(a).power_cycle(ms(20), 0);
  core.refresh(a);
  const NodeRef b = add("generic-404", 0x11);
  core.run_until(ms(2000));
  EXPECT_TRUE(tx.take().empty()) << "bus-off: no boot-up, no heartbeat";
  EXPECT_EQ(core.node(b).can_state(), CanState::kBusOff);
  inject({error_frame(CAN_ERR_RESTARTED)}, ms(2000));
  core.run_until(ms(3000));
  bool beat_a = false, beat_b = false;
  for (auto& s : tx.take()) {
    beat_a |= s.frame.id == 0x710;
    beat_b |= s.frame.id == 0x711;
  }
  EXPECT_TRUE(beat_a && beat_b);
}

TEST_F(NodeReactions, ABusOffFaultAndAControllerBusOffOverlap) {
  // The bus_off fault (a node's own controller) and the interface's: the
  // node is back only when both are over, with one recovery EMCY.
  const NodeRef a = add("generic-404", 0x10);
  core.run_until(ms(10));
  tx.take();
  core.node(a).set_bus_off(true, ms(10));
  inject({error_frame(CAN_ERR_BUSOFF)}, ms(20));
  core.node(a).set_bus_off(false, ms(30));
  core.refresh(a);
  EXPECT_TRUE(emcys().empty());
  inject({error_frame(CAN_ERR_RESTARTED)}, ms(40));
  EXPECT_EQ(emcys(), (std::vector<CanFrame>{F(0x90, {0x40, 0x81, 0x11, 0, 0, 0, 0, 0}),
                                            F(0x90, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0})}));
}

}  // namespace
}  // namespace cansim::io
