// NodeObserver (core/observer.hpp), LoopCore forwarding (LoopObserver) and
// local access as the device's own application (write_local, read_local,
// store_local / restore_local, nmt_local), frame by frame on the fake clock.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "io/loop_core.hpp"
#include "nmt_support.hpp"
#include "pdo_fixture.hpp"

namespace cansim::observer_test {
namespace {

using nmt_test::F;
using nmt_test::Harness;
using nmt_test::S;
using nmt_test::SimNode;

std::string hex(unsigned v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%0*X", digits, v);
  return buf;
}

std::string nmt_text(NmtState old, NmtState now) {
  return "nmt " + hex(unsigned(old), 2) + ">" + hex(unsigned(now), 2);
}

std::string emcy_text(std::uint16_t code, std::uint8_t reg, const std::uint8_t vendor[5]) {
  std::string s = "emcy " + hex(code, 4) + " reg " + hex(reg, 2) + " vendor ";
  for (int i = 0; i < 5; ++i) s += hex(vendor[i], 2);
  return s;
}

std::string write_text(const OdEntry& e, WriteVia via) {
  return "write " + hex(e.index, 4) + ":" + hex(e.sub, 2) + (via == WriteVia::kSdo ? " sdo" : " rpdo");
}

std::string power_text(bool powered) { return powered ? "power on" : "power off"; }

// Every event as "<time> <what>", one per line; the node passed must be the
// observed one.
class Recorder : public NodeObserver {
 public:
  explicit Recorder(Node& node) : node_(node) { node.set_observer(this); }
  ~Recorder() override { node_.set_observer(nullptr); }
  void on_nmt_state(Node& n, NmtState old, NmtState now, TimeUs t) override { add(n, t, nmt_text(old, now)); }
  void on_boot_up(Node& n, TimeUs t) override { add(n, t, "boot"); }
  void on_emcy(Node& n, std::uint16_t code, std::uint8_t reg, const std::uint8_t vendor[5], TimeUs t) override {
    add(n, t, emcy_text(code, reg, vendor));
  }
  void on_remote_write(Node& n, const OdEntry& e, WriteVia via, TimeUs t) override { add(n, t, write_text(e, via)); }
  void on_power(Node& n, bool powered, TimeUs t) override { add(n, t, power_text(powered)); }
  // The events since the last take().
  std::string take() {
    std::string out;
    out.swap(log_);
    return out;
  }

 private:
  void add(Node& n, TimeUs t, const std::string& what) {
    EXPECT_EQ(&n, &node_) << what;
    log_ += std::to_string(t) + " " + what + "\n";
  }
  Node& node_;
  std::string log_;
};

// An SDO request of node 5 (always 8 bytes).
CanFrame sdo5(std::initializer_list<std::uint8_t> bytes) {
  CanFrame f = F(0x605, bytes);
  f.dlc = 8;
  return f;
}

std::span<const std::uint8_t> le(std::uint64_t v, std::size_t size, std::uint8_t (&buf)[8]) {
  for (std::size_t i = 0; i < size; ++i) buf[i] = std::uint8_t(v >> (8 * i));
  return {buf, size};
}

class ObserverTest : public Harness {
 protected:
  // Node 5 powered on at `at` (the boot-up and its events already taken).
  SimNode& start(const std::string& options = "{}", const std::string& extra = "", Application* app = nullptr) {
    SimNode& n = add(5, options, extra, app);
    rec = std::make_unique<Recorder>(n.node());
    bus.power_on_all();
    take();
    rec->take();
    return n;
  }
  SdoAbort local(SimNode& n, std::uint16_t index, std::uint8_t sub, std::uint64_t v, std::size_t size) {
    std::uint8_t buf[8] = {};
    return n->write_local(*n->od().find(index, sub), le(v, size, buf), now());
  }
  std::string events() { return rec->take(); }

  std::unique_ptr<Recorder> rec;
};

std::string at(TimeUs t, const std::string& what) { return std::to_string(t) + " " + what + "\n"; }

// ---------------------------------------------------------------- NMT, boot-up, power

TEST_F(ObserverTest, NmtFramesAreObservedAtTheirTime) {
  SimNode& n = start();
  bus.run_until(ms(7));
  nmt(kNmtStart, 5);
  EXPECT_EQ(events(), at(ms(7), nmt_text(NmtState::kPreOperational, NmtState::kOperational)));
  bus.run_until(ms(9));
  nmt(kNmtStop, 0);
  nmt(kNmtStop, 0);   // no change: nothing
  nmt(kNmtStart, 6);  // another node
  EXPECT_EQ(events(), at(ms(9), nmt_text(NmtState::kOperational, NmtState::kStopped)));
  EXPECT_EQ(n->state(), NmtState::kStopped);
}

TEST_F(ObserverTest, PowerOnIsObservedWithOneBootUpAtTheFrame) {
  SimNode& n = add(5, "{boot_up_delay_ms: 150}");
  Recorder r(n.node());
  bus.run_until(ms(2));
  bus.power_on_all();
  EXPECT_EQ(r.take(), at(ms(2), power_text(true)));  // INITIALISING until the boot-up
  bus.run_until(ms(500));
  EXPECT_EQ(r.take(), at(ms(152), "boot") + at(ms(152), nmt_text(NmtState::kInitialising, NmtState::kPreOperational)));
  EXPECT_EQ(take(), S({{ms(152), F(0x705, {0x00})}}));
}

TEST_F(ObserverTest, NoBootUpObservedForANodeOffTheBus) {
  SimNode& on = add(5);
  SimNode& off = add(6);
  off->set_bus_bit_rate(1);  // the bus runs at another rate than the node
  Recorder r_on(on.node()), r_off(off.node());
  bus.power_on_all();
  EXPECT_EQ(take(), S({{0, F(0x705, {0x00})}}));
  EXPECT_EQ(r_on.take(), at(0, power_text(true)) + at(0, "boot") +
                             at(0, nmt_text(NmtState::kInitialising, NmtState::kPreOperational)));
  // It runs (NMT state) but its boot-up never reached the bus.
  EXPECT_EQ(r_off.take(),
            at(0, power_text(true)) + at(0, nmt_text(NmtState::kInitialising, NmtState::kPreOperational)));
}

TEST_F(ObserverTest, PowerCycleIsObservedOffAndOn) {
  SimNode& n = start();
  nmt(kNmtStart, 5);
  events();
  bus.run_until(ms(10));
  n->power_cycle(now(), ms(20));
  EXPECT_EQ(events(),
            at(ms(10), power_text(false)) + at(ms(10), nmt_text(NmtState::kOperational, NmtState::kInitialising)));
  bus.run_until(ms(29));
  EXPECT_EQ(events(), "");
  bus.run_until(ms(30));
  EXPECT_EQ(events(), at(ms(30), power_text(true)) + at(ms(30), "boot") +
                          at(ms(30), nmt_text(NmtState::kInitialising, NmtState::kPreOperational)));
}

TEST_F(ObserverTest, ResetNodeIsObservedThroughInitialising) {
  start();
  bus.run_until(ms(4));
  nmt(kNmtResetNode, 5);
  EXPECT_EQ(events(), at(ms(4), nmt_text(NmtState::kPreOperational, NmtState::kInitialising)) + at(ms(4), "boot") +
                          at(ms(4), nmt_text(NmtState::kInitialising, NmtState::kPreOperational)));
}

// ---------------------------------------------------------------- EMCY

const std::uint8_t kVendor[5] = {0x11, 0x22, 0x33, 0x44, 0x55};
const std::uint8_t kNoVendor[5] = {};

TEST_F(ObserverTest, EmcyIsObservedWhenSentAfterTheInhibitTimeNotWhenRaised) {
  SimNode& n = start();
  ASSERT_EQ(wr16(n, 0x1015, 0, 100), SdoAbort::kNone);  // 10 ms
  EXPECT_EQ(n->emcy().sent_count(), 0u);
  EXPECT_EQ(n->emcy().last_emcy().time, kNever);
  bus.run_until(ms(5));
  n->emcy().raise(0x5000, 0, now());
  bus.run_until(ms(6));
  n->emcy().raise(0x2310, 0, kVendor, now());  // inside the inhibit time: queued
  EXPECT_EQ(events(), at(ms(5), emcy_text(0x5000, 0x01, kNoVendor)));
  EXPECT_EQ(n->emcy().sent_count(), 1u);
  bus.run_until(ms(15) - 1);
  EXPECT_EQ(events(), "");
  bus.run_until(ms(15));
  EXPECT_EQ(events(), at(ms(15), emcy_text(0x2310, 0x03, kVendor)));
  EXPECT_EQ(take(), S({{ms(5), F(0x85, {0x00, 0x50, 0x01, 0, 0, 0, 0, 0})},
                       {ms(15), F(0x85, {0x10, 0x23, 0x03, 0x11, 0x22, 0x33, 0x44, 0x55})}}));
  EXPECT_EQ(n->emcy().sent_count(), 2u);
  const Emcy::Sent& last = n->emcy().last_emcy();
  EXPECT_EQ(last.time, ms(15));
  EXPECT_EQ(last.code, 0x2310);
  EXPECT_EQ(last.reg, 0x03);
  EXPECT_EQ(std::vector<std::uint8_t>(last.vendor, last.vendor + 5), std::vector<std::uint8_t>(kVendor, kVendor + 5));
}

TEST_F(ObserverTest, EmcyNotSentIsNotObservedNorCounted) {
  SimNode& n = start();
  n->set_muted(true);  // alive but sending nothing
  n->emcy().raise(0x5000, 0, now());
  nmt(kNmtStop, 5);
  events();
  n->set_muted(false);
  n->emcy().raise(0x4210, 0, now());  // STOPPED: recorded only (CiA 301 Table 82)
  EXPECT_EQ(events(), "");
  EXPECT_EQ(take(), "");
  EXPECT_EQ(n->emcy().sent_count(), 0u);
}

// ---------------------------------------------------------------- remote writes

TEST_F(ObserverTest, SdoDownloadsAreObservedOnceEachWhenStored) {
  SimNode& n = start();
  bus.run_until(ms(1));
  inject(sdo5({0x2B, 0x01, 0x20, 0x00, 0x34, 0x12, 0, 0}));  // expedited 0x2001 = 0x1234
  EXPECT_EQ(events(), at(ms(1), write_text(*n->od().find(0x2001, 0), WriteVia::kSdo)));
  EXPECT_EQ(n->values().u(0x2001, 0), 0x1234u);

  // Segmented, 10 bytes to 0x2002: observed with the last segment only.
  bus.run_until(ms(2));
  inject(sdo5({0x21, 0x02, 0x20, 0x00, 10, 0, 0, 0}));
  inject(sdo5({0x00, 'a', 'b', 'c', 'd', 'e', 'f', 'g'}));
  EXPECT_EQ(events(), "");
  bus.run_until(ms(3));
  inject(sdo5({0x19, 'h', 'i', 'j', 0, 0, 0, 0}));
  EXPECT_EQ(events(), at(ms(3), write_text(*n->od().find(0x2002, 0), WriteVia::kSdo)));

  // Block, 10 bytes to 0x2002: observed at the end request.
  bus.run_until(ms(4));
  inject(sdo5({0xC2, 0x02, 0x20, 0x00, 10, 0, 0, 0}));
  inject(sdo5({0x01, 'K', 'L', 'M', 'N', 'O', 'P', 'Q'}));
  inject(sdo5({0x82, 'R', 'S', 'T', 0, 0, 0, 0}));
  EXPECT_EQ(events(), "");
  bus.run_until(ms(5));
  inject(sdo5({0xD1, 0, 0, 0, 0, 0, 0, 0}));  // 4 bytes of the last segment unused
  EXPECT_EQ(events(), at(ms(5), write_text(*n->od().find(0x2002, 0), WriteVia::kSdo)));
  const auto text = n->values().bytes(*n->od().find(0x2002, 0));
  EXPECT_EQ(std::string(text.begin(), text.end()), "KLMNOPQRST");
  const auto sent = bus.take();
  ASSERT_FALSE(sent.empty());
  EXPECT_EQ(sent.back().frame, F(0x585, {0xA1, 0, 0, 0, 0, 0, 0, 0}));
}

TEST_F(ObserverTest, RefusedSdoDownloadsAreNotObserved) {
  SimNode& n = start();
  inject(sdo5({0x23, 0x00, 0x10, 0x00, 1, 2, 3, 4}));        // 0x1000 is read-only
  inject(sdo5({0x21, 0x00, 0x10, 0x00, 10, 0, 0, 0}));       // segmented, read-only
  inject(sdo5({0x2B, 0x01, 0x20, 0x00, 0x34, 0x12, 0, 0}));  // 0x2001 ...
  events();
  inject(sdo5({0x23, 0x01, 0x20, 0x00, 1, 2, 3, 4}));  // ... with 4 bytes: too long
  EXPECT_EQ(events(), "");
  EXPECT_EQ(n->values().u(0x1000, 0), 0x00020194u);
  const auto sent = bus.take();
  ASSERT_EQ(sent.size(), 4u);
  EXPECT_EQ(get_u32(sent[0].frame.data + 4), std::uint32_t(SdoAbort::kReadOnly));
  EXPECT_EQ(get_u32(sent[1].frame.data + 4), std::uint32_t(SdoAbort::kReadOnly));
  EXPECT_EQ(get_u32(sent[3].frame.data + 4), std::uint32_t(SdoAbort::kLengthTooHigh));
}

TEST(ObserverRpdo, EachMappedObjectOfAnRpdoIsObserved) {
  pdo_test::PdoBus b;
  Recorder r(b.node());
  b.start();
  r.take();
  b.bus().run_for(ms(3));
  const TimeUs t = b.now();
  b.bus().inject(F(0x205, {0x44, 0x33, 0x22, 0x11, 0x66, 0x55}));
  EXPECT_EQ(r.take(), at(t, write_text(*b.node().od().find(0x2000, 0), WriteVia::kRpdo)) +
                          at(t, write_text(*b.node().od().find(0x2001, 0), WriteVia::kRpdo)));
  EXPECT_EQ(b.value(0x2000, 0), 0x11223344u);
  EXPECT_EQ(b.value(0x2001, 0), 0x5566u);
  b.bus().inject(F(0x205, {0x01, 0x02, 0x03}));  // too short: not processed, EMCY 0x8210 instead
  EXPECT_EQ(r.take(), at(t, emcy_text(0x8210, 0x11, kNoVendor)));
}

// ---------------------------------------------------------------- local access

const char* kLocalObjects = R"(
  - {index: 0x2010, type: UNSIGNED16, access: ro, default: 5, low: 1, high: 1000}
  - {index: 0x2011, type: UNSIGNED32, access: wo, default: 9, hook: read}
  - {index: 0x2012, type: UNSIGNED8, access: const, default: 0, hook: write}
)";

// Refreshes 0x2011 with the time; refuses 13 for 0x2012 and counts its writes.
struct LocalApp : Application {
  int after_writes = 0;
  void refresh(Node& n, const OdEntry& e, TimeUs t) override { n.values().set_u(e, std::uint64_t(t)); }
  SdoAbort check_write(Node&, const OdEntry&, std::span<const std::uint8_t> d, TimeUs) override {
    return d[0] == 13 ? SdoAbort::kInvalidValue : SdoAbort::kNone;
  }
  void after_write(Node&, const OdEntry&, TimeUs) override { ++after_writes; }
};

TEST_F(ObserverTest, WriteLocalWritesReadOnlyObjectsWithinTheirLimits) {
  SimNode& n = start("{}", kLocalObjects);
  EXPECT_EQ(wr16(n, 0x2010, 0, 500), SdoAbort::kReadOnly);  // a master may not
  EXPECT_EQ(local(n, 0x2010, 0, 500, 2), SdoAbort::kNone);
  EXPECT_EQ(events(), "");  // a local write is no remote write
  bus.take();
  inject(sdo5({0x40, 0x10, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(take(), S({{0, F(0x585, {0x4B, 0x10, 0x20, 0x00, 0xF4, 0x01, 0, 0})}}));
  EXPECT_EQ(local(n, 0x2010, 0, 1001, 2), SdoAbort::kValueTooHigh);
  EXPECT_EQ(local(n, 0x2010, 0, 0, 2), SdoAbort::kValueTooLow);
  EXPECT_EQ(local(n, 0x2010, 0, 7, 1), SdoAbort::kLengthTooLow);
  EXPECT_EQ(n->values().u(0x2010, 0), 500u);
}

TEST_F(ObserverTest, WriteLocalRunsTheApplicationHooks) {
  LocalApp app;
  SimNode& n = start("{}", kLocalObjects, &app);
  EXPECT_EQ(local(n, 0x2012, 0, 7, 1), SdoAbort::kNone);  // const, hook: write
  EXPECT_EQ(app.after_writes, 1);
  EXPECT_EQ(local(n, 0x2012, 0, 13, 1), SdoAbort::kInvalidValue);
  EXPECT_EQ(app.after_writes, 1);
  EXPECT_EQ(n->values().u(0x2012, 0), 7u);
}

TEST_F(ObserverTest, ReadLocalReadsWriteOnlyObjectsRefreshed) {
  LocalApp app;
  SimNode& n = start("{}", kLocalObjects, &app);
  bus.run_until(ms(3));
  const OdEntry& e = *n->od().find(0x2011, 0);
  std::span<const std::uint8_t> out;
  EXPECT_EQ(n->read(e, now(), out), SdoAbort::kWriteOnly);
  ASSERT_EQ(n->read_local(e, now(), out), SdoAbort::kNone);
  ASSERT_EQ(out.size(), 4u);
  EXPECT_EQ(get_u32(out.data()), std::uint32_t(ms(3)));
}

TEST_F(ObserverTest, WriteLocalOfTheHeartbeatTimeRestartsTheProducer) {
  SimNode& n = start();
  bus.run_until(ms(10));
  ASSERT_EQ(local(n, 0x1017, 0, 50, 2), SdoAbort::kNone);
  bus.run_until(ms(110));
  EXPECT_EQ(take(), S({{ms(60), F(0x705, {0x7F})}, {ms(110), F(0x705, {0x7F})}}));
}

TEST_F(ObserverTest, StoreLocalKeepsValuesOverAPowerCycleRestoreLocalDropsThem) {
  SimNode& n = start();
  ASSERT_EQ(local(n, 0x2000, 0, 0x1234, 4), SdoAbort::kNone);  // persistent: application
  ASSERT_EQ(local(n, 0x2001, 0, 77, 2), SdoAbort::kNone);      // not persistent
  EXPECT_EQ(n->store_local(9, now()), SdoAbort::kNoSubIndex);
  EXPECT_EQ(n.storage.saves, 0);
  ASSERT_EQ(n->store_local(1, now()), SdoAbort::kNone);
  EXPECT_EQ(n.storage.saves, 1);
  n->power_cycle(now(), ms(1));
  bus.run_for(ms(1));
  EXPECT_EQ(n->state(), NmtState::kPreOperational);
  EXPECT_EQ(n->values().u(0x2000, 0), 0x1234u);
  EXPECT_EQ(n->values().u(0x2001, 0), 9u);

  ASSERT_EQ(n->restore_local(1, now()), SdoAbort::kNone);
  EXPECT_EQ(n->values().u(0x2000, 0), 0x1234u);  // effective at the next reset
  n->power_cycle(now(), ms(1));
  bus.run_for(ms(1));
  EXPECT_EQ(n->values().u(0x2000, 0), 7u);
  EXPECT_EQ(events().find("write"), std::string::npos);
}

TEST_F(ObserverTest, NmtLocalTakesTheMastersPath) {
  SimNode& n = add(5, "{boot_up_delay_ms: 10}");
  Recorder r(n.node());
  EXPECT_FALSE(n->nmt_local(kNmtResetNode, now()));  // unpowered
  bus.power_on_all();
  r.take();
  EXPECT_FALSE(n->nmt_local(kNmtStart, now()));  // before the boot-up
  bus.run_until(ms(10));
  take();
  r.take();
  EXPECT_FALSE(n->nmt_local(0x03, now()));
  EXPECT_TRUE(n->nmt_local(kNmtStart, now()));
  EXPECT_EQ(r.take(), at(ms(10), nmt_text(NmtState::kPreOperational, NmtState::kOperational)));
  bus.run_until(ms(15));
  EXPECT_TRUE(n->nmt_local(kNmtResetCommunication, now()));
  EXPECT_EQ(r.take(), at(ms(15), nmt_text(NmtState::kOperational, NmtState::kInitialising)));
  bus.run_until(ms(25));
  EXPECT_EQ(r.take(), at(ms(25), "boot") + at(ms(25), nmt_text(NmtState::kInitialising, NmtState::kPreOperational)));
  EXPECT_EQ(take(), S({{ms(25), F(0x705, {0x00})}}));
}

// ---------------------------------------------------------------- LoopCore

// Every event as "<ref> <time> <what>".
class LoopRecorder : public io::LoopObserver {
 public:
  void on_nmt_state(io::NodeRef r, NmtState old, NmtState now, TimeUs t) override { add(r, t, nmt_text(old, now)); }
  void on_boot_up(io::NodeRef r, TimeUs t) override { add(r, t, "boot"); }
  void on_emcy(io::NodeRef r, std::uint16_t code, std::uint8_t reg, const std::uint8_t vendor[5], TimeUs t) override {
    add(r, t, emcy_text(code, reg, vendor));
  }
  void on_remote_write(io::NodeRef r, const OdEntry& e, WriteVia via, TimeUs t) override {
    add(r, t, write_text(e, via));
  }
  void on_power(io::NodeRef r, bool powered, TimeUs t) override { add(r, t, power_text(powered)); }
  std::string take() {
    std::string out;
    out.swap(log);
    return out;
  }
  std::string log;

 private:
  void add(io::NodeRef r, TimeUs t, const std::string& what) { log += std::to_string(r) + " " + at(t, what); }
};

class LoopObserverTest : public ::testing::Test {
 protected:
  LoopObserverTest() : profile(test::load_repo_profile("generic-404")), tx(&core.now()) {
    bus = core.add_bus("vcan0", tx, 3);
  }
  io::NodeRef add(std::uint8_t id) { return core.add_node(bus, config::node_setup(profile, id)); }
  std::string on(io::NodeRef r, TimeUs t, const std::string& what) { return std::to_string(r) + " " + at(t, what); }
  std::string boot(io::NodeRef r, TimeUs t) {
    return on(r, t, power_text(true)) + on(r, t, "boot") +
           on(r, t, nmt_text(NmtState::kInitialising, NmtState::kPreOperational));
  }

  config::Profile profile;
  io::LoopCore core;
  io::MemoryTransport tx;
  io::BusId bus;
  LoopRecorder rec;
};

TEST_F(LoopObserverTest, ForwardsEveryNodesEventsWithItsNodeRef) {
  io::NodeRef a = add(1);
  core.set_observer(&rec);
  io::NodeRef b = add(2);  // added after set_observer: observed too
  core.power_on(a, 0);
  core.power_on(b, ms(1));
  EXPECT_EQ(rec.take(), boot(a, 0) + boot(b, ms(1)));
  core.receive(bus, F(0x000, {kNmtStart, 0x00}), ms(5));
  EXPECT_EQ(rec.take(), on(a, ms(5), nmt_text(NmtState::kPreOperational, NmtState::kOperational)) +
                            on(b, ms(5), nmt_text(NmtState::kPreOperational, NmtState::kOperational)));
  core.receive(bus, F(0x202, {1, 2, 3, 4, 5, 6}), ms(6));  // RPDO1 of node 2
  EXPECT_EQ(rec.take(), on(b, ms(6), write_text(*profile.layout->find(0x2100, 1), WriteVia::kRpdo)) +
                            on(b, ms(6), write_text(*profile.layout->find(0x2100, 2), WriteVia::kRpdo)));
  core.node(a).emcy().raise(0x5000, 0, core.now());
  core.refresh(a);
  EXPECT_EQ(rec.take(), on(a, ms(6), emcy_text(0x5000, 0x01, kNoVendor)));
}

TEST_F(LoopObserverTest, RefreshPicksUpTheDeadlineOfALocalWrite) {
  io::NodeRef a = add(1);
  core.set_observer(&rec);
  core.power_on(a, 0);
  core.run_until(ms(10));
  tx.take();
  rec.take();
  std::uint8_t buf[8] = {};
  Node& n = core.node(a);
  ASSERT_EQ(n.write_local(*n.od().find(0x1017, 0), le(50, 2, buf), core.now()), SdoAbort::kNone);
  core.refresh(a);  // generic-404 beats every 1000 ms: without this, the heap would wait for it
  core.run_until(ms(60));
  const auto sent = tx.take();
  ASSERT_EQ(sent.size(), 1u);
  EXPECT_EQ(sent[0].time, ms(60));
  EXPECT_EQ(sent[0].frame, F(0x701, {0x7F}));
  EXPECT_EQ(rec.take(), "");  // local, not remote
}

TEST_F(LoopObserverTest, RemovedNodesAndACoreWithoutObserverAreSilent) {
  io::NodeRef a = add(1), b = add(2);
  core.set_observer(&rec);
  core.power_on(a, 0);
  core.power_on(b, 0);
  rec.take();
  core.remove_node(b);
  EXPECT_EQ(rec.take(), "");
  core.set_observer(nullptr);
  EXPECT_EQ(core.node(a).observer(), nullptr);
  core.receive(bus, F(0x000, {kNmtStart, 0x00}), ms(1));
  EXPECT_EQ(core.node(a).state(), NmtState::kOperational);
  EXPECT_EQ(rec.take(), "");
}

}  // namespace
}  // namespace cansim::observer_test
