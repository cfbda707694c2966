// Node::snapshot / restore with Application::snapshot / restore: after
// traffic that changes OD values, PDO configuration, the NMT, SDO and LSS
// states, the heartbeat producer and consumer, the EMCY history, armed faults
// and the physics, restoring the snapshot taken after power-on gives a node
// that nothing tells apart from a freshly built one: the same OD values, and
// the same frames at the same times for the same following traffic.
#include <gtest/gtest.h>

#include <algorithm>
#include <initializer_list>
#include <memory>
#include <vector>

#include "personalities/registry.hpp"
#include "support/device.hpp"

namespace cansim {
namespace {

using test::Sent;

constexpr std::uint8_t kId = 0x10;  // generic-404's node-ID
constexpr std::uint32_t kSdoRx = 0x600 + kId;

// A node of generic-404 with its application (real physics) and storage,
// driven through frames and time; every frame it sends is kept with its time.
class Rig : public FrameSink {
 public:
  explicit Rig(const config::Profile& p)
      : app_(personalities::make_application(p, personalities::NodeContext{})),
        node_(setup_of(p), *this, app_.get(), &storage) {
    node_.power_on(0);
  }
  ~Rig() override = default;

  void send(const CanFrame& f) override { sent.push_back({now, f}); }

  // Runs every deadline up to t.
  void run_to(TimeUs t) {
    for (TimeUs next = node_.next_deadline(); next <= t; next = node_.next_deadline()) {
      now = std::max(now, next);
      node_.advance(now);
    }
    now = std::max(now, t);
  }
  void frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes, std::uint8_t dlc = 0xFF) {
    CanFrame f = CanFrame::make(id, bytes);
    if (dlc != 0xFF) f.dlc = dlc;
    node_.on_frame(f, now);
    run_to(now);
  }
  void sdo(std::initializer_list<std::uint8_t> bytes) { frame(kSdoRx, bytes, 8); }
  void sdo_to(std::uint8_t id, std::initializer_list<std::uint8_t> bytes) { frame(0x600u + id, bytes, 8); }
  void rtr(std::uint32_t id) {
    node_.on_frame(CanFrame::remote(id), now);
    run_to(now);
  }
  void lss(std::initializer_list<std::uint8_t> bytes) { frame(0x7E5, bytes, 8); }
  void arm(physics::FaultSpec f) { personalities::measurement_control(app_.get())->arm_fault(node_, f, now); }

  struct Saved {
    NodeSnapshot node;
    std::unique_ptr<Application> app;
    std::vector<std::uint8_t> storage;
  };
  Saved save() const { return {node_.snapshot(), app_->snapshot(), storage.data}; }
  void restore(const Saved& s, TimeUs at) {
    ASSERT_TRUE(node_.restore(s.node));
    app_->restore(*s.app);
    storage.data = s.storage;
    now = at;
    sent.clear();
  }

  Node& node() { return node_; }
  TimeUs now = 0;
  std::vector<Sent> sent;
  test::MemoryStorage storage;

 private:
  static NodeSetup setup_of(const config::Profile& p) {
    NodeSetup s;
    s.layout = p.layout;
    s.options = p.options;
    s.node_id = p.node_id;
    s.bit_rate_index = std::uint8_t(config::bit_rate_index(p.bit_rate_kbit));
    return s;
  }
  std::unique_ptr<Application> app_;
  Node node_;
};

// Leaves a trace in every part of the state.
void change_everything(Rig& r) {
  r.run_to(ms(10));
  r.frame(0x000, {0x01, kId});                              // NMT: OPERATIONAL
  r.sdo({0x23, 0x00, 0x21, 0x01, 0x78, 0x56, 0x34, 0x12});  // 0x2100:01 = 0x12345678
  r.sdo({0x2B, 0x17, 0x10, 0x00, 0x2C, 0x01});              // heartbeat 300 ms
  r.sdo({0x2B, 0x00, 0x18, 0x05, 0x32, 0x00});              // TPDO1 event timer 50 ms
  r.sdo({0x23, 0x01, 0x18, 0x01, 0x90, 0x02, 0x00, 0x80});  // TPDO2 not valid
  r.sdo({0x23, 0x31, 0x61, 0x01, 0x00, 0x00, 0x4E, 0xFD});  // 0x6131:01 mbar (chain unit)
  r.sdo({0x2F, 0x32, 0x61, 0x01, 0x03});                    // 0x6132:01 digits 3
  r.sdo({0x23, 0x16, 0x10, 0x01, 0xC8, 0x00, 0x20, 0x00});  // consume node 0x20, 200 ms
  r.frame(0x720, {0x05});                                   // its heartbeat: monitoring on
  r.sdo({0x23, 0x10, 0x10, 0x01, 's', 'a', 'v', 'e'});      // store all
  r.frame(0x080, {0x00, 0x00, 0x00});                       // SYNC with DLC 3: EMCY 0x8240
  physics::FaultSpec drift;
  drift.kind = physics::FaultKind::Drift;
  drift.drift_per_s = 5000.0;
  r.arm(drift);
  physics::FaultSpec slow_sdo;
  slow_sdo.kind = physics::FaultKind::SlowSdo;
  slow_sdo.sdo_delay_us = ms(3);
  r.arm(slow_sdo);
  r.run_to(r.now + ms(1500));   // consumer timeout, TPDOs, the physics moves on
  r.lss({0x04, 0x01});          // LSS: configuration state
  r.lss({0x11, 0x22});          // pending node-ID 0x22
  r.frame(0x000, {0x82, kId});  // reset communication: node-ID 0x22 from now on
  r.run_to(r.now + ms(5));
  r.sdo_to(0x22, {0x2B, 0x17, 0x10, 0x00, 0x00, 0x00});              // heartbeat off: guarding answers
  r.rtr(0x722);                                                      // the guarding toggle moves on
  r.sdo_to(0x22, {0x2B, 0x17, 0x10, 0x00, 0x2C, 0x01});              // heartbeat 300 ms again
  r.sdo_to(0x22, {0x23, 0x05, 0x10, 0x00, 0x81, 0x00, 0x00, 0x00});  // SYNC on 0x081
  r.lss({0x04, 0x01});                                               // configuration state again
  r.lss({0x11, 0x33});                                               // pending node-ID 0x33
  r.sdo_to(0x22, {0x40, 0x08, 0x10, 0x00});                          // segmented upload of 0x1008 left open
  r.run_to(r.now + ms(5));
  r.frame(0x000, {0x02, 0x00});  // NMT: STOPPED
  ASSERT_FALSE(r.sent.empty());
  physics::FaultSpec silent;  // last: the node falls silent and goes bus-off
  silent.kind = physics::FaultKind::Silent;
  r.arm(silent);
  physics::FaultSpec bus_off;
  bus_off.kind = physics::FaultKind::BusOff;
  r.arm(bus_off);
  r.run_to(r.now + ms(5));
  ASSERT_EQ(r.node().state(), NmtState::kStopped);
  ASSERT_EQ(r.node().node_id(), 0x22);
  physics::FaultSpec power_cycle;  // and loses power for 5 s
  power_cycle.kind = physics::FaultKind::PowerCycle;
  power_cycle.timing.duration_us = ms(5000);
  r.arm(power_cycle);
  r.run_to(r.now + ms(5));
  ASSERT_FALSE(r.node().powered());
}

// Traffic that shows each of those parts in the frames it draws.
std::vector<Sent> probe(Rig& r) {
  r.sent.clear();
  r.sdo({0x60});                       // segment request: only an open upload answers
  r.lss({0x5E});                       // inquire node-ID: only in configuration state
  r.sdo({0x40, 0x00, 0x21, 0x01});     // 0x2100:01
  r.sdo({0x40, 0x17, 0x10, 0x00});     // heartbeat time
  r.sdo({0x40, 0x00, 0x18, 0x05});     // TPDO1 event timer
  r.sdo({0x40, 0x03, 0x10, 0x00});     // EMCY history count
  r.sdo({0x40, 0x32, 0x61, 0x01});     // digits
  r.frame(0x000, {0x01, kId});         // OPERATIONAL
  r.frame(0x080, {0x00, 0x00, 0x00});  // EMCY 0x8240 with the error register
  r.frame(0x720, {0x05});              // a heartbeat of node 0x20
  for (int i = 0; i < 12; ++i) {       // TPDO1 (physics), TPDO2 on SYNC, heartbeats
    r.run_to(r.now + ms(200));
    r.frame(0x080, {});
  }
  r.sdo({0x2B, 0x17, 0x10, 0x00, 0x00, 0x00});  // heartbeat off: guarding answers
  r.rtr(0x700 + kId);                           // with its toggle
  r.rtr(0x700 + kId);
  r.frame(0x000, {0x81, kId});  // reset node: stored values, pending node-ID
  r.run_to(r.now + ms(1200));
  return r.sent;
}

std::string describe(const std::vector<Sent>& frames) {
  std::string s;
  for (const Sent& f : frames) {
    s += std::to_string(f.time) + " " + std::to_string(f.frame.id) + ":";
    for (int i = 0; i < f.frame.dlc; ++i) s += " " + std::to_string(f.frame.data[i]);
    s += "\n";
  }
  return s;
}

bool same_frames(const std::vector<Sent>& a, const std::vector<Sent>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].time != b[i].time || !(a[i].frame == b[i].frame)) return false;
  return true;
}

class NodeSnapshots : public ::testing::Test {
 protected:
  config::Profile profile = test::prepared_repo_profile("generic-404");
};

TEST_F(NodeSnapshots, RestoredNodeIsIndistinguishableFromAFreshOne) {
  Rig used(profile);
  const Rig::Saved at_power_on = used.save();
  ASSERT_NE(at_power_on.app, nullptr);
  change_everything(used);
  used.restore(at_power_on, 0);

  Rig fresh(profile);
  for (const OdEntry& e : profile.layout->entries()) {
    const auto a = used.node().values().bytes(e), b = fresh.node().values().bytes(e);
    EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin(), b.end())) << std::hex << e.index << ":" << int(e.sub);
  }
  EXPECT_EQ(used.node().state(), fresh.node().state());
  EXPECT_EQ(used.node().node_id(), fresh.node().node_id());

  const std::vector<Sent> after_restore = probe(used);
  const std::vector<Sent> after_build = probe(fresh);
  EXPECT_GT(after_build.size(), 30u);
  EXPECT_TRUE(same_frames(after_restore, after_build)) << "restored:\n"
                                                       << describe(after_restore) << "fresh:\n"
                                                       << describe(after_build);
}

// The probe tells the two apart when the snapshot is not restored: it sees
// what change_everything() left behind.
TEST_F(NodeSnapshots, TheProbeSeesTheTrafficWithoutARestore) {
  Rig used(profile);
  change_everything(used);
  used.now = 0;
  used.sent.clear();
  Rig fresh(profile);
  EXPECT_FALSE(same_frames(probe(used), probe(fresh)));
}

// A snapshot restored twice gives the same run twice (nothing of the first
// run stays behind), also from a state in the middle of traffic.
TEST_F(NodeSnapshots, RestoringTwiceRepeatsTheRun) {
  Rig r(profile);
  r.run_to(ms(700));
  r.frame(0x000, {0x01, kId});
  const Rig::Saved midway = r.save();
  const TimeUs t = r.now;
  const std::vector<Sent> first = probe(r);
  change_everything(r);
  r.restore(midway, t);
  EXPECT_TRUE(same_frames(probe(r), first));
}

TEST_F(NodeSnapshots, RefusesASnapshotOfAnotherLayout) {
  Rig r(profile);
  config::Profile other = test::prepared_repo_profile("generic-404");  // a layout of its own
  Rig stranger(other);
  stranger.frame(0x000, {0x01, kId});
  EXPECT_FALSE(r.node().restore(stranger.node().snapshot()));
  EXPECT_NE(r.node().state(), NmtState::kOperational);
}

}  // namespace
}  // namespace cansim
