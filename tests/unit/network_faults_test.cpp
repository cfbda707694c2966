// The network faults frame by frame on a fake clock: generic-404
// nodes with their real application, the faults in the profile's `faults:`
// (or armed as ArmFault arms them), on the loop core's ideal or timed bus.
// Each test says what leaves, when, and that the fleet seed reproduces it.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <set>

#include "config/physics_config.hpp"
#include "io/loop_core.hpp"
#include "io/wire_bits.hpp"
#include "personalities/measurement_control.hpp"
#include "personalities/registry.hpp"
#include "support/sim.hpp"

namespace cansim::test {
namespace {

using io::BusModel;
using io::MemoryTransport;
using Log = std::vector<MemoryTransport::Sent>;

constexpr std::uint8_t kId = 0x10;
constexpr std::uint32_t kHb = 0x700 + kId, kTpdo1 = 0x180 + kId, kSdoRx = 0x600 + kId, kSdoTx = 0x580 + kId;
constexpr std::uint8_t k250 = 3, k125 = 4;

// generic-404 nodes 0x10.. with `faults`, on one bus of the loop core.
class Fleet {
 public:
  explicit Fleet(const std::string& faults, BusModel model = BusModel::kIdeal, std::uint8_t rate = k250,
                 std::uint64_t seed = 1, int nodes = 1)
      : tx(&core.now()) {
    const std::string path = std::string(CANSIM_SOURCE_DIR) + "/profiles/generic-404.yaml";
    YAML::Node root = YAML::LoadFile(path);
    root["faults"] = YAML::Load(faults);
    profile = config::parse_profile(root, path);
    bus = core.add_bus("vcan0", tx, rate);
    core.set_bus_model(bus, model);
    for (int i = 0; i < nodes; ++i) {
      NodeSetup s = config::node_setup(profile, std::uint8_t(kId + i));
      s.bit_rate_index = rate;
      personalities::NodeContext ctx;
      ctx.fleet_seed = seed;
      ctx.index = std::uint32_t(i);
      ctx.key = "vcan0/g/" + std::to_string(i);
      refs.push_back(core.add_node(bus, s, personalities::make_application(profile, ctx)));
    }
    for (io::NodeRef r : refs) core.power_on(r, 0);
  }
  void master(const CanFrame& f, TimeUs t) {
    core.run_until(t);
    core.receive(bus, f, t);
  }
  void start(TimeUs t) { master(F(0x000, {0x01, 0x00}), t); }
  // Frames on `id` (all: 0) sent in [from, to).
  Log sent(TimeUs from, TimeUs to, std::uint32_t id = 0) const {
    Log out;
    for (const auto& s : tx.log)
      if (s.time >= from && s.time < to && (id == 0 || s.frame.id == id)) out.push_back(s);
    return out;
  }
  std::vector<TimeUs> times(TimeUs from, TimeUs to, std::uint32_t id) const {
    std::vector<TimeUs> t;
    for (const auto& s : sent(from, to, id)) t.push_back(s.time);
    return t;
  }
  Node& node(int i = 0) { return core.node(refs[std::size_t(i)]); }
  personalities::MeasurementControl& control(int i = 0) {
    return *personalities::measurement_control(core.app(refs[std::size_t(i)]));
  }

  config::Profile profile;
  io::LoopCore core;
  MemoryTransport tx;
  io::BusId bus = 0;
  std::vector<io::NodeRef> refs;
};

std::string dump(const Log& log) {
  std::string s;
  for (const auto& e : log) s += std::to_string(e.time) + " " + to_string(e.frame) + "\n";
  return s;
}

// TPDO1 every 100 ms from the start at 50 ms: 150, 250, ... ms.
std::vector<TimeUs> tpdo_times(TimeUs from, TimeUs to) {
  std::vector<TimeUs> t;
  for (TimeUs x = ms(150); x < to; x += ms(100))
    if (x >= from) t.push_back(x);
  return t;
}

// ---------------------------------------------------------------- frame faults

TEST(FrameFaults, DropAChosenServiceWithAProbabilityTheSeedReproduces) {
  const std::string fault = "[{kind: frame_drop, service: tpdo1, probability: 0.5, at: 1 s, duration: 2 s}]";
  auto run = [&](std::uint64_t seed) {
    Fleet f(fault, BusModel::kIdeal, k250, seed);
    f.start(ms(50));
    f.core.run_until(ms(4000));
    // Outside the fault every TPDO leaves; the heartbeat is never touched.
    EXPECT_EQ(f.times(0, ms(1000), kTpdo1), tpdo_times(0, ms(1000)));
    EXPECT_EQ(f.times(ms(3000), ms(4000), kTpdo1), tpdo_times(ms(3000), ms(4000)));
    EXPECT_EQ(f.times(ms(900), ms(4000), kHb), (std::vector<TimeUs>{ms(1000), ms(2000), ms(3000)}));
    return f.times(ms(1000), ms(3000), kTpdo1);
  };
  const std::vector<TimeUs> a = run(1), again = run(1), other = run(2);
  EXPECT_EQ(a, again);  // the same seed: the same frames lost
  EXPECT_NE(a, other);
  // 20 TPDOs in the window, each kept with probability 0.5.
  EXPECT_GT(a.size(), 3u);
  EXPECT_LT(a.size(), 17u);
}

TEST(FrameFaults, DelayWithJitterHoldsEachFrameWithinItsWindow) {
  Fleet f("[{kind: frame_delay, service: heartbeat, delay: 30 ms, jitter: 10 ms, at: 1.5 s, duration: 2 s}]");
  f.core.run_until(ms(6000));
  const std::vector<TimeUs> beats = f.times(ms(500), ms(6000), kHb);
  ASSERT_EQ(beats.size(), 5u);
  EXPECT_EQ(beats[0], ms(1000));
  EXPECT_EQ(beats[3], ms(4000));  // the fault ended at 3.5 s
  for (int k : {1, 2}) {
    EXPECT_GE(beats[std::size_t(k)], ms(1000) * (k + 1) + ms(30));
    EXPECT_LE(beats[std::size_t(k)], ms(1000) * (k + 1) + ms(40));
  }
  EXPECT_NE(beats[1] - ms(2000), beats[2] - ms(3000));  // jitter: not the same delay twice (this seed)
}

TEST(FrameFaults, FreezeKeepsTheFirstFramesData) {
  Fleet f("[{kind: frame_freeze, service: tpdo1, at: 1 s, duration: 1 s}]");
  f.start(ms(50));
  f.core.run_until(ms(2500));
  const Log during = f.sent(ms(1000), ms(2000), kTpdo1);
  ASSERT_EQ(during.size(), 10u);
  for (const auto& s : during) EXPECT_EQ(s.frame, during[0].frame) << dump(during);
  // Before and after, the pressure's noise moves the value.
  const Log before = f.sent(0, ms(1000), kTpdo1), after = f.sent(ms(2000), ms(2500), kTpdo1);
  EXPECT_NE(before[0].frame, before[1].frame);
  EXPECT_NE(after[0].frame, during[0].frame);
}

TEST(FrameFaults, CorruptChosenBytesOrOneRandomByte) {
  Fleet f(R"([{kind: frame_corrupt, service: tpdo1, bytes: [0, 4], value: 0xA5, at: 1 s, duration: 0.5 s},
              {kind: frame_corrupt, cob_id: 0x710, at: 2 s, duration: 3 s}])");
  f.start(ms(50));
  f.core.run_until(ms(5500));
  for (const auto& s : f.sent(ms(1000), ms(1500), kTpdo1)) {
    ASSERT_EQ(s.frame.dlc, 5);
    EXPECT_EQ(s.frame.data[0], 0xA5);
    EXPECT_EQ(s.frame.data[4], 0xA5);
  }
  EXPECT_NE(f.sent(ms(1500), ms(1600), kTpdo1).at(0).frame.data[4], 0xA5);
  // The heartbeat's one byte, operational 0x05, with random bits flipped.
  for (const auto& s : f.sent(ms(2000), ms(5000), kHb)) EXPECT_NE(s.frame.data[0], 0x05) << to_string(s.frame);
  EXPECT_EQ(f.sent(ms(5000), ms(5001), kHb).at(0).frame, F(kHb, {0x05}));
}

// The streams start again at each power-on (core/fault_random.hpp): a bench
// that power-cycles a node sees the same faulted frames after the cycle
// whether the cycle came after three heartbeats or four. The n-th power-on
// has its own stream: the second cycle does not replay the first.
TEST(FrameFaults, APowerCycleStartsTheSeededStreamsAgainWhateverWentBefore) {
  const std::string faults = R"([{kind: frame_corrupt, service: heartbeat, bytes: [0], probability: 0.5},
                                 {kind: frame_drop, service: heartbeat, probability: 0.3}])";
  // The heartbeats of each power-on, as (time after its boot-up, frame).
  using Beats = std::vector<std::pair<TimeUs, CanFrame>>;
  auto after_cycles = [&](const std::vector<TimeUs>& cycles_at, std::uint64_t seed = 7) {
    Fleet f(faults, BusModel::kIdeal, k250, seed);
    for (TimeUs at : cycles_at) {
      f.core.run_until(at);
      f.node().power_cycle(at, ms(300));
      f.core.refresh(f.refs[0]);
    }
    const TimeUs end = cycles_at.back() + ms(40000);
    f.core.run_until(end);
    std::vector<TimeUs> from{0};
    from.insert(from.end(), cycles_at.begin(), cycles_at.end());
    std::vector<Beats> runs;
    for (std::size_t i = 0; i < from.size(); ++i) {
      const Log log = f.sent(from[i], i + 1 < from.size() ? from[i + 1] : end, kHb);
      EXPECT_EQ(log.at(0).frame, F(kHb, {0x00})) << "boot-up of power-on " << i + 1 << dump(log);
      Beats beats;
      for (std::size_t k = 1; k < log.size(); ++k) beats.push_back({log[k].time - log[0].time, log[k].frame});
      runs.push_back(beats);
    }
    return runs;
  };
  const auto early = after_cycles({ms(3200), ms(50000)}), late = after_cycles({ms(4200), ms(51000)});
  // Three heartbeats were due before the first cycle in one run, four in the
  // other; after it, the same frames.
  auto first = [](const Beats& b) { return Beats(b.begin(), b.begin() + std::min<std::ptrdiff_t>(20, b.size())); };
  ASSERT_GE(early[1].size(), 20u);
  ASSERT_GE(early[2].size(), 20u);
  EXPECT_EQ(early[1], late[1]);
  EXPECT_EQ(early[2], late[2]);
  EXPECT_NE(first(early[1]), first(early[2]));  // each power-on has its own stream
  EXPECT_NE(first(early[1]), first(after_cycles({ms(3200), ms(50000)}, 8)[1]));
  // The faults did act: some heartbeats corrupted, some lost.
  const auto corrupted =
      std::count_if(early[1].begin(), early[1].end(), [](const auto& b) { return b.second.data[0] != 0x7F; });
  EXPECT_GT(corrupted, 3);
  EXPECT_LT(early[1].size(), 44u);  // of 46
}

TEST(FrameFaults, DlcChangesTheLengthPaddingWithZeros) {
  Fleet f(R"([{kind: frame_dlc, service: tpdo1, dlc: 2, at: 1 s, duration: 0.5 s},
              {kind: frame_dlc, service: heartbeat, dlc: 8, at: 2 s, duration: 0.5 s}])");
  f.start(ms(50));
  f.core.run_until(ms(2600));
  for (const auto& s : f.sent(ms(1000), ms(1500), kTpdo1)) EXPECT_EQ(s.frame.dlc, 2);
  EXPECT_EQ(f.sent(ms(1500), ms(1600), kTpdo1).at(0).frame.dlc, 5);
  EXPECT_EQ(f.sent(ms(2000), ms(2001), kHb).at(0).frame, F(kHb, {0x05, 0, 0, 0, 0, 0, 0, 0}));
}

TEST(FrameFaults, DuplicateSendsEachFrameTwice) {
  Fleet f("[{kind: frame_duplicate, service: heartbeat, at: 1.5 s, duration: 2 s}]", BusModel::kTimed);
  f.core.run_until(ms(4100));
  EXPECT_EQ(f.sent(ms(1500), ms(3500), kHb).size(), 4u);
  EXPECT_EQ(f.sent(ms(3500), ms(4100), kHb).size(), 1u);
  // On a timed bus the copy follows the frame, back to back.
  const Log two = f.sent(ms(2000), ms(2100), kHb);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[1].time - two[0].time, io::wire_bits(two[0].frame) * 4);  // 4 µs a bit at 250 kbit/s
}

TEST(FrameFaults, FramesFromOutsideMayBeLostOrLate) {
  // The node misses SDO requests for 1 s and hears NMT 20 ms late.
  Fleet f(R"([{kind: frame_drop, cob_id: 0x610, at: 1 s, duration: 1 s},
              {kind: frame_delay, cob_id: 0x000, delay: 20 ms, at: 1 s}])");
  const CanFrame upload = F(kSdoRx, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});
  f.master(upload, ms(500));
  f.master(upload, ms(1200));
  f.core.run_until(ms(1300));
  EXPECT_EQ(f.times(0, ms(1300), kSdoTx), (std::vector<TimeUs>{ms(500)}));
  f.master(F(0x000, {0x01, 0x00}), ms(1300));
  f.core.run_until(ms(1319));
  EXPECT_EQ(f.node().state(), NmtState::kPreOperational);
  f.core.run_until(ms(1320));
  EXPECT_EQ(f.node().state(), NmtState::kOperational);
  f.master(upload, ms(2100));
  f.core.run_until(ms(2200));
  EXPECT_EQ(f.times(ms(1300), ms(2200), kSdoTx), (std::vector<TimeUs>{ms(2100)}));
}

TEST(FrameFaults, OutsideFramesOnATimedBusHoldTheWireWhateverTheNodeHears) {
  // A lossy harness on a timed bus at 125 kbit/s: the node misses one SDO
  // request and hears the next 5 ms late; both requests occupied the wire
  // (the answer to the second follows it by its delay and its own length).
  Fleet f(R"([{kind: frame_drop, cob_id: 0x610, at: 1 s, duration: 100 ms},
              {kind: frame_delay, cob_id: 0x610, delay: 5 ms, at: 1.2 s, duration: 100 ms}])",
          BusModel::kTimed, k125);
  const CanFrame upload = F(kSdoRx, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});
  f.master(upload, ms(1050));
  f.master(upload, ms(1250));
  f.core.run_until(ms(1400));
  const Log answers = f.sent(ms(1000), ms(1400), kSdoTx);
  ASSERT_EQ(answers.size(), 1u) << dump(answers);
  const CanFrame answer = answers[0].frame;
  EXPECT_EQ(answers[0].time, ms(1255) + TimeUs(io::wire_bits(answer) - 3) * 8);  // its EOF, before the intermission
  EXPECT_EQ(f.core.stats().frames_in, 2u);                                       // both were on the wire
}

TEST(FrameFaults, ArmedAtRunTimeLikeAProfileFault) {
  Fleet f("[]");
  f.start(ms(50));
  f.core.run_until(ms(1000));
  const physics::FaultSpec spec =
      config::parse_fault_text("<ArmFault>", "frame_drop", {{"service", "tpdo1"}, {"duration", "500 ms"}});
  f.control().arm_fault(f.node(), spec, f.core.now());
  f.core.refresh(f.refs[0]);
  f.core.run_until(ms(2000));
  EXPECT_EQ(f.times(ms(1000), ms(2000), kTpdo1), tpdo_times(ms(1500), ms(2000)));
}

TEST(FrameFaults, ParametersAreCheckedWhereTheyAreGiven) {
  auto error = [](const std::string& kind, std::vector<std::pair<std::string, std::string>> keys) {
    try {
      config::parse_fault_text("<ArmFault>", kind, keys);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("frame_drop", {}).find("missing 'service'"), std::string::npos);
  EXPECT_NE(error("frame_drop", {{"service", "tpdo0"}}).find("expected tpdo1..tpdo512"), std::string::npos);
  EXPECT_NE(error("frame_drop", {{"service", "tpdo513"}}).find("expected tpdo1..tpdo512"), std::string::npos);
  EXPECT_NE(error("frame_drop", {{"service", "sdo"}, {"cob_id", "0x590"}}).find("not both"), std::string::npos);
  EXPECT_NE(error("frame_drop", {{"service", "sdo"}, {"delay", "1 s"}}).find("delay: not a parameter of frame_drop"),
            std::string::npos);
  EXPECT_NE(error("frame_drop", {{"service", "sdo"}, {"probability", "1.5"}}).find("probability"), std::string::npos);
  EXPECT_NE(error("frame_dlc", {{"service", "sdo"}, {"dlc", "9"}}).find("0..8"), std::string::npos);
  EXPECT_NE(error("babbling", {{"cob_id", "0x100"}}).find("rate"), std::string::npos);
  EXPECT_NE(error("sdo_abort", {{"index", "0x6130"}}).find("missing required key 'code'"), std::string::npos);
  EXPECT_NE(error("sdo_silent", {{"sub", "1"}}).find("needs an index"), std::string::npos);
  EXPECT_NE(error("error_frames", {{"class", "meteor"}}).find("expected warning, passive"), std::string::npos);
  EXPECT_EQ(error("frame_corrupt", {{"cob_id", "0x123"}, {"bytes", "[1, 7]"}, {"value", "0x55"}}), "");
  const physics::FaultSpec s =
      config::parse_fault_text("<x>", "error_frames", {{"class", "passive"}, {"period", "100 ms"}});
  EXPECT_EQ(s.net.error_period_us, ms(100));
  EXPECT_EQ(s.timing.period_us, 0);  // error_frames' period is the error frames', not a repeat
}

// ---------------------------------------------------------------- network faults

TEST(NetworkFaults, NodeIdCollisionASecondNodeAnswersAtTheSameId) {
  Fleet f("[{kind: node_id_collision, at: 1.5 s, duration: 2 s}]", BusModel::kTimed, k125);
  f.core.run_until(ms(1500) + ms(5));
  // The twin boots at the fault's start: a boot-up of node 0x10 out of the blue.
  EXPECT_EQ(f.sent(ms(1500), ms(1505), kHb).size(), 1u);
  EXPECT_EQ(f.sent(ms(1500), ms(1505), kHb).at(0).frame, F(kHb, {0x00}));
  // Identical answers (the device type, the same in both) are one frame on
  // the wire; the serial numbers differ (1, 2): a collision, 16 error
  // frames for the master, the dominant one first (...01 before ...02).
  const CanFrame device_type = F(kSdoRx, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});
  const CanFrame serial = F(kSdoRx, {0x40, 0x18, 0x10, 0x04, 0, 0, 0, 0});
  f.master(device_type, ms(1600));
  f.core.run_until(ms(1650));
  EXPECT_EQ(f.sent(ms(1600), ms(1650), kSdoTx).size(), 1u);
  EXPECT_TRUE(f.tx.errors.empty());
  f.master(serial, ms(1700));
  f.core.run_until(ms(1800));
  const Log answers = f.sent(ms(1700), ms(1800), kSdoTx);
  ASSERT_EQ(answers.size(), 2u) << dump(answers);
  EXPECT_EQ(answers[0].frame.data[4], 1);
  EXPECT_EQ(answers[1].frame.data[4], 2);
  EXPECT_EQ(f.tx.errors.size(), std::size_t(io::TimedBus::kCollisionAttempts));
  for (const auto& e : f.tx.errors) EXPECT_EQ(e.error, BusError::kStuff);
  // Both heartbeat, each on its own period from its boot (the node's at 2
  // and 3 s, the twin's at 2.5 s); after the fault, only the node.
  f.core.run_until(ms(5500));
  const TimeUs eof = (io::wire_bits(F(kHb, {0x7F})) - 3) * 8;
  EXPECT_EQ(f.times(ms(1800), ms(3500), kHb), (std::vector<TimeUs>{ms(2000) + eof, ms(2500) + eof, ms(3000) + eof}))
      << dump(f.sent(ms(1400), ms(5500)));
  EXPECT_EQ(f.sent(ms(3500), ms(5500), kHb).size(), 2u);
}

TEST(NetworkFaults, BabblingStarvesHigherIdentifiersOnATimedBus) {
  // 0x100 with 8 bytes at the whole bus's rate from 1 s for 1 s: its
  // controller always has a frame waiting, so the heartbeat 0x710 (a higher
  // identifier) waits until the babbling ends, then leaves after the two
  // frames still in the babbler's buffer (with the next one, due at 2 s).
  Fleet f("[{kind: babbling, cob_id: 0x100, duty: 1.0, at: 1 s, duration: 1 s}]", BusModel::kTimed, k125);
  f.core.run_until(ms(2000));
  EXPECT_GE(f.core.bus_load(f.bus).carried_1s, 0.99);  // the babbling second
  EXPECT_LE(f.core.bus_load(f.bus).carried_1s, 1.0);
  f.core.run_until(ms(3500));
  EXPECT_EQ(f.times(ms(900), ms(2000), kHb), std::vector<TimeUs>{});
  const std::vector<TimeUs> babble = f.times(ms(1000), ms(3500), 0x100);
  const int bits = io::wire_bits(F(0x100, {0, 0, 0, 0, 0, 0, 0, 0}));
  // Back to back for the whole second: 1 s / (bits x 8 µs), and the two after.
  EXPECT_NEAR(double(babble.size()), 1e6 / (bits * 8.0) + 2, 2.0);
  for (std::size_t i = 1; i < babble.size(); ++i) ASSERT_EQ(babble[i] - babble[i - 1], bits * 8) << i;
  // The heartbeat of 1 s (starved) and the one of 2 s, back to back.
  const int hb_bits = io::wire_bits(F(kHb, {0x7F}));
  EXPECT_EQ(f.times(ms(2000), ms(2100), kHb),
            (std::vector<TimeUs>{babble.back() + hb_bits * 8, babble.back() + 2 * hb_bits * 8}));
  EXPECT_EQ(f.core.bus_load(f.bus).dropped, 0u);
}

TEST(NetworkFaults, SdoAbortAnswersTheChosenCode) {
  Fleet f("[{kind: sdo_abort, index: 0x6130, sub: 1, code: 0x08000022}]");
  f.master(F(kSdoRx, {0x40, 0x30, 0x61, 0x01, 0, 0, 0, 0}), ms(100));
  f.master(F(kSdoRx, {0x40, 0x30, 0x61, 0x02, 0, 0, 0, 0}), ms(200));
  f.core.run_until(ms(300));
  const Log a = f.sent(ms(100), ms(300), kSdoTx);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0].frame, F(kSdoTx, {0x80, 0x30, 0x61, 0x01, 0x22, 0x00, 0x00, 0x08}));
  EXPECT_EQ(a[1].frame.data[0], 0x43);  // sub 2: the value
}

TEST(NetworkFaults, SdoSilentAnObjectOrTheWholeServer) {
  Fleet f("[{kind: sdo_silent, index: 0x1018}, {kind: sdo_silent, at: 1 s, duration: 1 s}]");
  f.master(F(kSdoRx, {0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}), ms(100));
  f.master(F(kSdoRx, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), ms(200));
  f.master(F(kSdoRx, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), ms(1500));
  f.master(F(kSdoRx, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), ms(2500));
  f.core.run_until(ms(3000));
  EXPECT_EQ(f.times(0, ms(3000), kSdoTx), (std::vector<TimeUs>{ms(200), ms(2500)}));
}

TEST(NetworkFaults, SdoToggleErrorFlipsTheSegmentsToggleBit) {
  Fleet f("[{kind: sdo_toggle_error}]");
  f.master(F(kSdoRx, {0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}), ms(100));  // 0x1008, a long string: segmented
  f.master(F(kSdoRx, {0x60, 0, 0, 0, 0, 0, 0, 0}), ms(110));           // first segment, toggle 0
  f.core.run_until(ms(200));
  const Log a = f.sent(ms(100), ms(200), kSdoTx);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0].frame.data[0] & 0xE0, 0x40);
  EXPECT_EQ(a[1].frame.data[0] & 0x10, 0x10);  // toggle 1 where 0 is due
}

// The toggle error's draws start again at each power-on, as the frame
// faults' do: after the cycle the same segments are wrong, however many
// went before it.
TEST(NetworkFaults, SdoToggleErrorStartsAgainAtPowerOn) {
  auto toggles_after_cycle = [](int uploads_before) {
    Fleet f("[{kind: sdo_toggle_error, probability: 0.5}]");
    TimeUs t = ms(100);
    auto upload = [&] {  // 0x1008 (a long string), initiate and first segment: its toggle bit
      f.master(F(kSdoRx, {0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}), t);
      f.master(F(kSdoRx, {0x60, 0, 0, 0, 0, 0, 0, 0}), t + ms(10));
      f.master(F(kSdoRx, {0x80, 0x08, 0x10, 0x00, 0, 0, 0, 0}), t + ms(20));  // abort: the next starts afresh
      f.core.run_until(t + ms(30));
      const Log answers = f.sent(t + ms(10), t + ms(20), kSdoTx);
      t += ms(50);
      return answers.empty() ? -1 : answers[0].frame.data[0] & 0x10;
    };
    for (int i = 0; i < uploads_before; ++i) upload();
    f.core.run_until(t);
    f.node().power_cycle(t, ms(300));
    f.core.refresh(f.refs[0]);
    t += ms(400);
    std::vector<int> bits;
    for (int i = 0; i < 16; ++i) bits.push_back(upload());
    return bits;
  };
  const std::vector<int> after3 = toggles_after_cycle(3), after6 = toggles_after_cycle(6);
  EXPECT_EQ(after3, after6);
  EXPECT_EQ(std::count(after3.begin(), after3.end(), -1), 0);
  const auto wrong = std::count(after3.begin(), after3.end(), 0x10);  // toggle 1 where 0 is due
  EXPECT_GT(wrong, 2);
  EXPECT_LT(wrong, 14);
}

TEST(NetworkFaults, ClockDriftRunsTheHeartbeatFast) {
  Fleet f("[{kind: clock_drift, ppm: 10000, at: 0.5 s, duration: 10 s}]");  // 1 % fast
  f.core.run_until(ms(5000));
  // From the beat at 1 s on: 1000 ms / 1.01 = 990.099 ms each.
  EXPECT_EQ(f.times(0, ms(5000), kHb), (std::vector<TimeUs>{0, ms(1000), 1990099, 2980198, 3970297, 4960396}));
}

TEST(NetworkFaults, ErrorFramesForTheMasterEveryPeriodAndTheWayBack) {
  Fleet f(R"([{kind: error_frames, class: passive, period: 100 ms, at: 1 s, duration: 350 ms},
              {kind: error_frames, class: stuff, at: 2 s, duration: 1 s}])",
          BusModel::kTimed);
  f.core.run_until(ms(3500));
  using E = MemoryTransport::Error;
  EXPECT_EQ(f.tx.errors, (std::vector<E>{{ms(1000), BusError::kPassive},
                                         {ms(1100), BusError::kPassive},
                                         {ms(1200), BusError::kPassive},
                                         {ms(1300), BusError::kPassive},
                                         {ms(1350), BusError::kActive},
                                         {ms(2000), BusError::kStuff}}));
  // The node itself goes on as before: no EMCY, error active.
  EXPECT_EQ(f.node().can_state(), CanState::kErrorActive);
  EXPECT_EQ(f.node().emcy().sent_count(), 0u);
}

}  // namespace
}  // namespace cansim::test
