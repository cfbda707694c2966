// Communication faults from a profile's `faults:` section, frame by frame on
// a fake clock: silent, power cycle, bus-off, heartbeat stop, slow SDO, SDO
// block segments dropped, and the vendor EMCYs of bus-off recovery and of an
// EEPROM / data-set error at boot.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "daemon/daemon.hpp"
#include "personalities/registry.hpp"
#include "support/sim.hpp"

namespace cansim::test {
namespace {

// One node of profiles/<name>.yaml with its real application and the given faults.
class FaultNode {
 public:
  // serial: the node of a fleet entry with `serial:` (NodeSetup::serial_number).
  FaultNode(const std::string& name, const std::string& faults, std::uint8_t node_id = 0,
            std::optional<std::uint32_t> serial = std::nullopt) {
    const std::string path = std::string(CANSIM_SOURCE_DIR) + "/profiles/" + name + ".yaml";
    YAML::Node root = YAML::LoadFile(path);
    root["faults"] = YAML::Load(faults);
    profile = config::parse_profile(root, path);
    personalities::NodeContext ctx;
    ctx.key = "vcan0/" + name;
    app = personalities::make_application(profile, ctx);
    id = node_id ? node_id : profile.node_id;
    node = &bus.add(profile, id, app.get(), serial);
    bus.power_on_all();
  }

  // Frames sent in [from, to) on one COB-ID (all when id == 0).
  std::vector<Sent> sent(TimeUs from, TimeUs to, std::uint32_t cob = 0) {
    std::vector<Sent> out;
    for (const Sent& s : bus.log())
      if (s.time >= from && s.time < to && (cob == 0 || s.frame.id == cob)) out.push_back(s);
    return out;
  }
  std::vector<TimeUs> times(TimeUs from, TimeUs to, std::uint32_t cob) {
    std::vector<TimeUs> t;
    for (const Sent& s : sent(from, to, cob)) t.push_back(s.time);
    return t;
  }
  void sdo(std::initializer_list<std::uint8_t> bytes) { bus.inject(F(0x600u + id, bytes)); }
  void nmt(std::uint8_t cs) { bus.inject(F(0x000, {cs, id})); }

  config::Profile profile;
  std::unique_ptr<Application> app;
  SimBus bus;
  SimNode* node = nullptr;
  std::uint8_t id = 0;
};

constexpr std::uint32_t kHb = 0x700 + 0x10;
constexpr std::uint32_t kEmcy = 0x80 + 0x10;
constexpr std::uint32_t kTpdo1 = 0x180 + 0x10;
constexpr std::uint32_t kSdoTx = 0x580 + 0x10;

TEST(CommFaults, SilentNodeSendsNothingButStillHears) {
  FaultNode n("generic-404", "[{kind: silent, at: 2.5 s, duration: 3 s}]");
  n.bus.run_until(ms(3000));
  n.nmt(0x01);  // start, while silent: heard
  n.bus.run_until(ms(7100));
  EXPECT_EQ(n.times(0, ms(7100), kHb), (std::vector<TimeUs>{0, ms(1000), ms(2000), ms(6000), ms(7000)}));
  EXPECT_TRUE(n.sent(ms(2500), ms(5500)).empty());
  // The start command took effect: operational heartbeat and PDOs after the silence.
  EXPECT_EQ(n.sent(ms(6000), ms(6001), kHb).at(0).frame, F(kHb, {0x05}));
  EXPECT_FALSE(n.sent(ms(5500), ms(6000), kTpdo1).empty());
}

TEST(CommFaults, AFleetSerialNumberKeepsFaultsAndOutlivesResets) {
  FaultNode n("generic-404", "[{kind: silent, at: 0.5 s, duration: 1 s}]", 0, 4711);
  n.bus.run_until(ms(3100));
  EXPECT_EQ(n.times(0, ms(3100), kHb), (std::vector<TimeUs>{0, ms(2000), ms(3000)}));
  std::span<const std::uint8_t> out;
  ASSERT_EQ(n.node->node().read(0x1018, 4, ms(3100), out), SdoAbort::kNone);
  EXPECT_EQ(decode_u(DataType::kUnsigned32, out.data()), 4711u);
  for (std::uint8_t reset : {0x82, 0x81}) {  // reset communication, reset node: 0x1018 back to its defaults
    n.nmt(reset);
    n.bus.run_for(ms(10));
    ASSERT_EQ(n.node->node().read(0x1018, 4, n.bus.now(), out), SdoAbort::kNone);
    EXPECT_EQ(decode_u(DataType::kUnsigned32, out.data()), 4711u) << "after NMT 0x" << std::hex << int(reset);
  }
}

TEST(CommFaults, PowerCycleBootsAgainWithStoredValuesAndLosesVolatileOnes) {
  FaultNode n("generic-404", "[{kind: power_cycle, at: 2.5 s, duration: 500 ms}]");
  n.bus.run_until(ms(100));
  n.sdo({0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01, 0, 0});    // 0x1017 = 500 ms
  n.sdo({0x23, 0x10, 0x10, 0x01, 's', 'a', 'v', 'e'});  // store all
  n.sdo({0x2B, 0x17, 0x10, 0x00, 0xC8, 0x00, 0, 0});    // 0x1017 = 200 ms, not stored
  n.nmt(0x01);
  n.bus.run_until(ms(3400));
  EXPECT_TRUE(n.sent(ms(2500), ms(3000)).empty()) << to_string(n.sent(ms(2500), ms(3000)));
  auto boot = n.sent(ms(3000), ms(3001), kHb);
  ASSERT_EQ(boot.size(), 1u);
  EXPECT_EQ(boot[0].frame, F(kHb, {0x00}));  // boot-up
  // Stored 500 ms kept, unstored 200 ms lost; pre-operational again after the reboot.
  n.bus.run_until(ms(4100));
  EXPECT_EQ(n.times(ms(3000) + 1, ms(4100), kHb), (std::vector<TimeUs>{ms(3500), ms(4000)}));
  EXPECT_EQ(n.sent(ms(3500), ms(3501), kHb).at(0).frame, F(kHb, {0x7F}));
  EXPECT_TRUE(n.sent(ms(3000), ms(4100), kTpdo1).empty());
}

TEST(CommFaults, ImmediatePowerCycleWithoutDuration) {
  FaultNode n("generic-404", "[{kind: power_cycle, at: 1.5 s}]");
  n.bus.run_until(ms(1600));
  auto hb = n.sent(0, ms(1600), kHb);
  ASSERT_EQ(hb.size(), 3u) << to_string(hb);
  EXPECT_EQ(hb[2].time, ms(1500));
  EXPECT_EQ(hb[2].frame, F(kHb, {0x00}));
}

TEST(CommFaults, BusOffSilencesTheNodeAndRecoveryReportsEmcy8140) {
  FaultNode n("generic-404", "[{kind: bus_off, at: 2.5 s, duration: 1 s}]");
  n.nmt(0x01);
  n.bus.run_until(ms(3000));
  n.nmt(0x02);  // stop, during bus-off: not heard
  n.bus.run_until(ms(4100));
  EXPECT_TRUE(n.sent(ms(2500), ms(3500)).empty());
  auto emcy = n.sent(ms(3500), ms(3501), kEmcy);
  ASSERT_EQ(emcy.size(), 2u) << to_string(n.sent(ms(3500), ms(3501)));
  EXPECT_EQ(emcy[0].frame, F(kEmcy, {0x40, 0x81, 0x11, 0, 0, 0, 0, 0}));
  EXPECT_EQ(emcy[1].frame, F(kEmcy, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0}));
  // 0x1029:01 = 0: bus-off took the node from OPERATIONAL to PRE-OPERATIONAL;
  // the heartbeat resumes on its grid.
  EXPECT_EQ(n.sent(ms(4000), ms(4001), kHb).at(0).frame, F(kHb, {0x7F}));
  std::span<const std::uint8_t> out;
  ASSERT_EQ(n.node->node().read(0x1003, 1, ms(4100), out), SdoAbort::kNone);
  EXPECT_EQ(decode_u(DataType::kUnsigned32, out.data()) & 0xFFFF, 0x8140u);
}

TEST(CommFaults, HeartbeatStopKeepsTheGridAndTheRestOfTheTraffic) {
  FaultNode n("generic-404", "[{kind: heartbeat_stop, at: 1.5 s, duration: 2 s}]");
  n.nmt(0x01);
  n.bus.run_until(ms(5100));
  EXPECT_EQ(n.times(0, ms(5100), kHb), (std::vector<TimeUs>{0, ms(1000), ms(4000), ms(5000)}));
  EXPECT_EQ(n.sent(ms(1500), ms(3500), kTpdo1).size(), 20u);  // 100 ms event timer
}

TEST(CommFaults, SlowSdoDelaysEveryAnswerInOrder) {
  FaultNode n("generic-404", "[{kind: slow_sdo, at: 1 s, duration: 10 s, sdo_delay: 300 ms}]");
  n.bus.run_until(ms(500));
  n.sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(n.times(ms(500), ms(501), kSdoTx).size(), 1u);  // before the fault: at once
  n.bus.run_until(ms(2000));
  n.sdo({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0});  // 0x1008, segmented
  n.bus.run_until(ms(2299));
  EXPECT_TRUE(n.sent(ms(2000), ms(2299), kSdoTx).empty());
  n.bus.run_until(ms(2300));
  auto init = n.sent(ms(2300), ms(2301), kSdoTx);
  ASSERT_EQ(init.size(), 1u);
  EXPECT_EQ(init[0].frame.data[0], 0x41);
  n.sdo({0x60, 0, 0, 0, 0, 0, 0, 0});
  n.bus.run_until(ms(2700));
  auto seg = n.sent(ms(2300) + 1, ms(2700), kSdoTx);
  ASSERT_EQ(seg.size(), 1u);
  EXPECT_EQ(seg[0].time, ms(2600));
  EXPECT_EQ(seg[0].frame.data[0], 0x00);
  EXPECT_EQ(seg[0].frame.data[1], 'c');
}

// Block upload of a 35-byte DOMAIN (5 segments) with every 4th segment lost:
// the client's ackseq makes the server resend from the gap.
TEST(CommFaults, SdoBlockDropLosesSegmentsAndTheTransferRecovers) {
  FaultNode n("generic-404", "[{kind: sdo_block_drop, at: 1 s, drop_every: 4}]");
  n.bus.run_until(ms(10));
  // Segmented download of 35 bytes into 0x2001 before the fault.
  n.sdo({0x21, 0x01, 0x20, 0x00, 35, 0, 0, 0});
  for (std::uint8_t i = 0; i < 5; ++i) {
    const std::uint8_t t = std::uint8_t((i & 1) << 4);
    const std::uint8_t b = std::uint8_t(i * 7);
    n.sdo({std::uint8_t(t | (i == 4 ? 0x01 : 0x00)), b, std::uint8_t(b + 1), std::uint8_t(b + 2), std::uint8_t(b + 3),
           std::uint8_t(b + 4), std::uint8_t(b + 5), std::uint8_t(b + 6)});
  }
  n.bus.run_until(ms(1000));
  n.bus.take();
  n.sdo({0xA0, 0x01, 0x20, 0x00, 127, 0, 0, 0});  // block upload initiate, blksize 127
  n.sdo({0xA3, 0, 0, 0, 0, 0, 0, 0});             // start
  auto sub1 = n.bus.take();
  ASSERT_EQ(sub1.size(), 5u) << to_string(sub1);  // initiate response + segments 1, 2, 3, 5
  EXPECT_EQ(sub1[1].frame.data[0], 0x01);
  EXPECT_EQ(sub1[3].frame.data[0], 0x03);
  EXPECT_EQ(sub1[4].frame.data[0], 0x85);  // the last one; segment 4 was lost
  n.sdo({0xA2, 3, 127, 0, 0, 0, 0, 0});    // ack up to 3: resend from segment 4
  auto sub2 = n.bus.take();
  ASSERT_EQ(sub2.size(), 2u) << to_string(sub2);
  EXPECT_EQ(sub2[0].frame, F(kSdoTx, {0x01, 21, 22, 23, 24, 25, 26, 27}));
  EXPECT_EQ(sub2[1].frame, F(kSdoTx, {0x82, 28, 29, 30, 31, 32, 33, 34}));
  n.sdo({0xA2, 2, 127, 0, 0, 0, 0, 0});
  auto end = n.bus.take();
  ASSERT_EQ(end.size(), 1u);
  EXPECT_EQ(end[0].frame.data[0] & 0xE3, 0xC1);
  EXPECT_EQ(n.node->node().sdo().dropped_segments(), 1u);
}

// Block download of 21 bytes, every 2nd segment lost: the server sees a gap
// and acknowledges the last good segment; when the resend loses its first
// segment, the stall acknowledge (70 % of the timeout) asks for it again.
TEST(CommFaults, SdoBlockDropAlsoLosesDownloadSegments) {
  FaultNode n("generic-404", "[{kind: sdo_block_drop, at: 0 s, drop_every: 2}]");
  n.bus.run_until(ms(10));
  n.bus.take();
  n.sdo({0xC2, 0x01, 0x20, 0x00, 21, 0, 0, 0});  // block download initiate, size 21
  ASSERT_EQ(n.bus.take().size(), 1u);
  n.sdo({0x01, 1, 2, 3, 4, 5, 6, 7});
  n.sdo({0x02, 8, 9, 10, 11, 12, 13, 14});  // lost
  EXPECT_TRUE(n.bus.take().empty());
  n.sdo({0x83, 15, 16, 17, 18, 19, 20, 21});
  auto ack = n.bus.take();
  ASSERT_EQ(ack.size(), 1u) << to_string(ack);
  EXPECT_EQ(ack[0].frame, F(kSdoTx, {0xA2, 1, 127, 0, 0, 0, 0, 0}));
  n.sdo({0x01, 8, 9, 10, 11, 12, 13, 14});    // the resend: lost again (4th)
  n.sdo({0x82, 15, 16, 17, 18, 19, 20, 21});  // 5th: out of sequence, ignored
  EXPECT_TRUE(n.bus.take().empty());
  n.bus.run_for(ms(700));
  auto stall = n.sent(ms(10), ms(2000), kSdoTx);
  ASSERT_EQ(stall.size(), 1u) << to_string(stall);
  EXPECT_EQ(stall[0].frame, F(kSdoTx, {0xA2, 0, 127, 0, 0, 0, 0, 0}));
  n.bus.take();
  n.sdo({0x01, 8, 9, 10, 11, 12, 13, 14});    // 6th: lost
  n.sdo({0x82, 15, 16, 17, 18, 19, 20, 21});  // 7th: out of sequence, ignored
  n.bus.run_for(ms(1000));
  auto end = n.sent(ms(10), ms(3000), kSdoTx);
  ASSERT_EQ(end.size(), 2u) << to_string(end);  // stall acknowledge, then the timeout
  EXPECT_EQ(end[0].frame, F(kSdoTx, {0xA2, 0, 127, 0, 0, 0, 0, 0}));
  EXPECT_EQ(end[1].frame, F(kSdoTx, {0x80, 0x01, 0x20, 0x00, 0x00, 0x00, 0x04, 0x05}));
  EXPECT_EQ(n.node->node().sdo().dropped_segments(), 3u);
}

// Per device: the bus-off recovery EMCY and the boot EMCY of an EEPROM /
// data-set error, as each manual lists them.
struct DeviceCase {
  const char* profile;
  std::vector<std::uint8_t> bus_off_emcy;  // first 3 bytes of the recovery EMCY
  std::vector<std::uint8_t> eeprom_emcy;   // first 5 bytes of the boot EMCY
};

class DeviceFaults : public ::testing::TestWithParam<DeviceCase> {};

std::vector<std::uint8_t> head(const CanFrame& f, std::size_t n) { return {f.data, f.data + n}; }

TEST_P(DeviceFaults, BusOffRecoveryEmcy) {
  FaultNode n(GetParam().profile, "[{kind: bus_off, at: 1.5 s, duration: 200 ms}]");
  n.bus.run_until(ms(1800));
  const std::uint32_t emcy = 0x80u + n.id;
  auto frames = n.sent(ms(1700), ms(1701), emcy);
  ASSERT_GE(frames.size(), 1u) << to_string(n.sent(ms(1500), ms(1800)));
  EXPECT_EQ(head(frames[0].frame, 3), GetParam().bus_off_emcy);
  EXPECT_TRUE(n.sent(ms(1500), ms(1700)).empty());
}

TEST_P(DeviceFaults, EepromErrorAtBootAfterAPowerCycle) {
  if (GetParam().eeprom_emcy.empty()) GTEST_SKIP() << "no EEPROM error EMCY in this manual";
  FaultNode n(GetParam().profile,
              "[{kind: eeprom_error, at: 1 s, duration: 2 s}, {kind: power_cycle, at: 1.5 s, duration: 100 ms}]");
  n.bus.run_until(ms(1400));
  const std::uint32_t emcy = 0x80u + n.id;
  EXPECT_TRUE(n.sent(0, ms(1400), emcy).empty()) << to_string(n.sent(0, ms(1400), emcy));
  n.bus.run_until(ms(2000));
  auto frames = n.sent(ms(1600), ms(2000), emcy);
  ASSERT_GE(frames.size(), 1u) << to_string(n.sent(ms(1500), ms(2000)));
  EXPECT_EQ(head(frames[0].frame, GetParam().eeprom_emcy.size()), GetParam().eeprom_emcy);
}

INSTANTIATE_TEST_SUITE_P(Devices, DeviceFaults,
                         ::testing::Values(DeviceCase{"generic-404", {0x40, 0x81, 0x11}, {}},
                                           DeviceCase{"dps", {0x40, 0x81, 0x11}, {0x00, 0x50, 0x81}},
                                           DeviceCase{"p92c", {0x00, 0x81, 0x11}, {0x00, 0x63, 0x01}},
                                           DeviceCase{"gems9000", {0x40, 0x81, 0x88}, {0x02, 0x61}},
                                           DeviceCase{"smc", {0x40, 0x81, 0x00}, {}},
                                           DeviceCase{
                                               "cmp", {0x40, 0x81, 0x11}, {0x00, 0x63, 0x01, 0x00, 0x00, 0x00, 0x30}}),
                         [](const auto& info) {
                           std::string s = info.param.profile;
                           for (char& c : s)
                             if (c == '-') c = '_';
                           return s;
                         });

}  // namespace
}  // namespace cansim::test
