// Fleet1.QueueFrames over a real sd-bus peer connection on the fake clock
// (what cansimctl replay calls): frames reach the bus and its nodes at their
// times, the bus's queue takes what fits, and every bound and malformed frame
// is refused naming it, taking nothing.
#include <gtest/gtest.h>

#include <algorithm>

#include "config/limits.hpp"
#include "control/names.hpp"
#include "support/control_fleet.hpp"

namespace cansim::test {
namespace {

constexpr const char* kFleet = R"(
interfaces: {vcan0: {bit_rate: 250, bus_model: ideal}}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 0x10, name: pt}
)";

struct Frame {
  std::int64_t t;
  std::uint32_t can_id;  // SocketCAN: bit 31 29-bit, bit 30 remote
  std::uint8_t dlc;
  std::vector<std::uint8_t> data;
};

class QueueFramesTest : public ::testing::Test {
 protected:
  ControlFleet fleet{kFleet};
  BusPair bus{fleet.service()};
  void SetUp() override {
    fleet.run_until(100'000);
    fleet.take("vcan0");
  }
  // The number taken, or the error's name.
  std::string queue(const std::string& iface, const std::vector<Frame>& frames) {
    sd_bus_message* m = bus.fleet_call("QueueFrames");
    sd_bus_message_append(m, "s", iface.c_str());
    sd_bus_message_open_container(m, 'a', "(xuyay)");
    for (const Frame& f : frames) {
      sd_bus_message_open_container(m, 'r', "xuyay");
      sd_bus_message_append(m, "xuy", f.t, f.can_id, f.dlc);
      sd_bus_message_append_array(m, 'y', f.data.data(), f.data.size());
      sd_bus_message_close_container(m);
    }
    sd_bus_message_close_container(m);
    std::string name;
    sd_bus_message* r = bus.call(m, &name, &message);
    if (!r) return name;
    std::uint32_t taken = 0;
    sd_bus_message_read(r, "u", &taken);
    sd_bus_message_unref(r);
    return std::to_string(taken);
  }
  std::string message;
};

TEST_F(QueueFramesTest, FramesGoOnTheBusAtTheirTimesAndTheNodesHearThem) {
  EXPECT_EQ(queue("vcan0", {{300'000, 0x610, 8, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}},
                            {200'000, 0x80000000u | 0x18DAF110u, 2, {1, 2}},
                            {250'000, 0x40000000u | 0x123u, 3, {}}}),
            "3");
  fleet.run_until(400'000);
  const auto sent = fleet.take("vcan0");
  ASSERT_EQ(sent.size(), 4u);
  EXPECT_EQ(sent[0].time, 200'000);
  EXPECT_EQ(sent[0].frame.id, 0x18DAF110u);
  EXPECT_TRUE(sent[0].frame.extended());
  EXPECT_EQ(sent[1].time, 250'000);
  EXPECT_TRUE(sent[1].frame.rtr());
  EXPECT_EQ(sent[1].frame.dlc, 3);
  EXPECT_EQ(sent[2].time, 300'000);
  EXPECT_EQ(sent[2].frame, F(0x610, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(sent[3].time, 300'000);  // the node answered the replayed request
  EXPECT_EQ(sent[3].frame.id, 0x590u);
}

TEST_F(QueueFramesTest, TheBusQueueTakesWhatFits) {
  std::vector<Frame> batch(limits::kQueueFramesPerCall, Frame{1'000'000, 0x7F0, 1, {0}});
  for (std::size_t n = 0; n < limits::kQueuedFramesPerBus / limits::kQueueFramesPerCall; ++n)
    ASSERT_EQ(queue("vcan0", batch), std::to_string(limits::kQueueFramesPerCall));
  EXPECT_EQ(queue("vcan0", batch), "0");
  fleet.run_until(1'000'000);
  const auto sent = fleet.take("vcan0");
  EXPECT_EQ(std::count_if(sent.begin(), sent.end(), [](const auto& s) { return s.frame.id == 0x7F0; }),
            std::ptrdiff_t(limits::kQueuedFramesPerBus));
  EXPECT_EQ(queue("vcan0", batch), std::to_string(limits::kQueueFramesPerCall));
}

TEST_F(QueueFramesTest, BoundsAndMalformedFramesAreRefusedTakingNothing) {
  std::vector<Frame> too_many(limits::kQueueFramesPerCall + 1, Frame{200'000, 0x7F0, 0, {}});
  EXPECT_EQ(queue("vcan0", too_many), control::kErrorTooLarge);
  EXPECT_EQ(message, "QueueFrames takes at most 1024 frames a call");
  EXPECT_EQ(queue("vcan0", {{200'000, 0x7F0, 0, {}}, {100'000 + limits::kQueueAheadUs + 1, 0x7F0, 0, {}}}),
            control::kErrorOutOfRange);
  EXPECT_EQ(message, "frame 1: its time is more than 10 s ahead");
  const std::pair<Frame, const char*> bad[] = {
      {{200'000, 0x20000004u, 8, {0, 4, 0, 0, 0, 0, 0, 0}}, "frame 0: error frames are not sent"},
      {{200'000, 0x800, 0, {}}, "frame 0: an 11-bit identifier above 0x7FF (bit 31 marks a 29-bit one)"},
      {{200'000, 0x123, 9, {1, 2, 3, 4, 5, 6, 7, 8, 9}}, "frame 0: a DLC above 8 (classic CAN only)"},
      {{200'000, 0x123, 2, {1}}, "frame 0: data of the DLC's length (none for a remote frame)"},
      {{200'000, 0x40000000u | 0x123u, 1, {1}}, "frame 0: data of the DLC's length (none for a remote frame)"},
  };
  for (const auto& [f, why] : bad) {
    EXPECT_EQ(queue("vcan0", {f}), control::kErrorInvalidArgument) << why;
    EXPECT_EQ(message, why);
  }
  EXPECT_EQ(queue("vcan9", {{200'000, 0x123, 0, {}}}), control::kErrorInvalidArgument);
  EXPECT_EQ(message, "no interface 'vcan9' in the fleet");
  fleet.run_until(20'000'000);
  for (const auto& sent : fleet.take("vcan0"))  // the node's own frames only
    EXPECT_EQ(sent.frame.id, 0x710u) << to_string(sent.frame);
}

}  // namespace
}  // namespace cansim::test
