// The journal knows what a bench did (control/audit.hpp): each acting method
// logs one line naming its node (key, interface), the action with its
// arguments, the caller's uid and the outcome; reads do not; a flood is cut
// to a burst per window and the rest counted.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>

#include "control/audit.hpp"
#include "control/service.hpp"
#include "support/control_fleet.hpp"

namespace cansim::test {
namespace {

using control::ActionLimiter;
using control::ActionRecord;

constexpr const char* kFleet = R"(
interfaces: {vcan0: {bit_rate: 250}}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 0x10, count: 2, name: generic}
  - {profile: dps, interface: vcan0, bit_rate: 250, name: dps}
)";

class RecordingFleet : public ControlFleet {
 public:
  using ControlFleet::ControlFleet;
  void log_action(const ActionRecord& r) override { lines.push_back(r); }
  std::vector<ActionRecord> lines;
};

class ControlAuditTest : public ::testing::Test {
 protected:
  RecordingFleet fleet{kFleet};
  BusPair bus{fleet.service()};

  void SetUp() override { fleet.run_until(5000); }

  std::string path_of(const std::string& node) { return bus.node_path(node); }
  template <typename... Args>
  void node_call(const std::string& node, const char* member, const char* sig, Args... args) {
    sd_bus_message* m = bus.node_call(path_of(node), member);
    if (sig && *sig) sd_bus_message_append(m, sig, args...);
    if (sd_bus_message* r = bus.call(m)) sd_bus_message_unref(r);
  }
  std::string uid_text() const { return "by uid " + std::to_string(geteuid()); }
};

TEST_F(ControlAuditTest, EachActionLogsItsNodeArgumentsCallerAndOutcome) {
  node_call("generic/0", "Ramp", "sdsd", "pressure", 3.0, "bar", 2.0);
  node_call("dps", "Write", "qyv", 0x1017, 0, "x", std::int64_t(70000));
  sd_bus_message* m = bus.node_call(path_of("generic/1"), "ArmFault");
  sd_bus_message_append(m, "sa{ss}", "open", 1, "duration", "1 s");
  sd_bus_message_unref(bus.call(m));
  node_call("generic/1", "Nmt", "s", "start");
  ASSERT_EQ(fleet.lines.size(), 4u);
  EXPECT_EQ(fleet.lines[0].node, "vcan0/generic/0");
  EXPECT_EQ(fleet.lines[0].interface, "vcan0");
  EXPECT_EQ(fleet.lines[0].text, "control: vcan0/generic/0: Ramp pressure 3 bar 2 " + uid_text() + ": done");
  ASSERT_TRUE(fleet.lines[0].uid.has_value());
  EXPECT_EQ(*fleet.lines[0].uid, geteuid());
  EXPECT_EQ(fleet.lines[1].text.substr(0, fleet.lines[1].text.find(" (")),
            "control: vcan0/dps/0: Write 0x1017:00 70000 " + uid_text() + ": refused");
  EXPECT_NE(fleet.lines[1].text.find("(OutOfRange: "), std::string::npos) << fleet.lines[1].text;
  EXPECT_EQ(fleet.lines[2].text, "control: vcan0/generic/1: ArmFault open {duration=1 s} " + uid_text() + ": done");
  EXPECT_EQ(fleet.lines[3].text, "control: vcan0/generic/1: Nmt start " + uid_text() + ": done");
}

TEST_F(ControlAuditTest, ReadsAreNotLoggedFleetActionsAre) {
  node_call("generic/0", "Read", "qy", 0x1018, 4);
  sd_bus_message_unref(bus.call(bus.node_call(path_of("generic/0"), "ListObjects")));
  sd_bus_message_unref(bus.call(bus.fleet_call("ListNodes")));
  EXPECT_TRUE(fleet.lines.empty());
  sd_bus_message* m = bus.fleet_call("RemoveNode");
  sd_bus_message_append(m, "s", "dps");
  sd_bus_message_unref(bus.call(m));
  ASSERT_EQ(fleet.lines.size(), 1u);
  EXPECT_EQ(fleet.lines[0].node, "vcan0/dps/0") << "the line names the node it removed";
  EXPECT_EQ(fleet.lines[0].text, "control: vcan0/dps/0: RemoveNode dps " + uid_text() + ": done");
}

TEST_F(ControlAuditTest, AFloodIsCutToTheBurst) {
  for (int i = 0; i < 200; ++i) node_call("generic/0", "Nmt", "s", i % 2 ? "start" : "preop");
  EXPECT_EQ(fleet.lines.size(), 50u);
}

TEST(ActionLimiter, BurstPerWindowThenTheSuppressedCount) {
  using namespace std::chrono_literals;
  ActionLimiter limit(3, 1s);
  const auto t0 = ActionLimiter::Clock::time_point() + 100s;
  std::size_t logged = 0;
  for (int i = 0; i < 5; ++i) logged += limit.admit(t0 + i * 10ms).log;
  EXPECT_EQ(logged, 3u);
  ActionLimiter::Admission next = limit.admit(t0 + 1100ms);
  EXPECT_TRUE(next.log);
  ASSERT_TRUE(next.suppressed);
  EXPECT_EQ(next.suppressed->text, "control: 2 action line(s) suppressed (more than 3 in 1 s)");
  EXPECT_EQ(next.suppressed->node, "");
  EXPECT_FALSE(limit.admit(t0 + 1110ms).suppressed) << "the count is told once";
  EXPECT_FALSE(limit.flush());
  for (int i = 0; i < 3; ++i) limit.admit(t0 + 1200ms);
  auto owed = limit.flush();
  ASSERT_TRUE(owed);
  EXPECT_EQ(owed->text, "control: 2 action line(s) suppressed (more than 3 in 1 s)");
}

}  // namespace
}  // namespace cansim::test
