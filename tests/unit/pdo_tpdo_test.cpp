// TPDO transmission (CiA 301 §7.2.2, Table 72): event timer, inhibit time,
// application events, synchronous types, SYNC start value, RTR, NMT gating.
#include "unit/pdo_fixture.hpp"

namespace cansim::pdo_test {
namespace {

const CanFrame kTpdo1 = F(0x185, {0x44, 0x33, 0x22, 0x11, 0x66, 0x55});
const CanFrame kTpdo2 = F(0x285, {0x88});

TEST(Tpdo, EventTimerPeriodsDoNotDriftOver100Periods) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1800, 5, 10), SdoAbort::kNone);
  b.start();
  const TimeUs t0 = b.now();
  b.bus().run_for(ms(1000) + 500);
  auto frames = b.sent(0x185);
  ASSERT_EQ(frames.size(), 100u);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    EXPECT_EQ(frames[k].time, t0 + ms(10) * TimeUs(k + 1)) << k;
    EXPECT_EQ(frames[k].frame, kTpdo1);
  }
}

TEST(Tpdo, NothingInPreOperationalOrStopped) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1800, 5, 10), SdoAbort::kNone);
  b.node().pdo().raise_event(1, b.now());
  b.sync();
  b.bus().run_for(ms(50));
  EXPECT_TRUE(b.bus().take().empty());  // pre-operational
  b.start();
  b.bus().run_for(ms(10));
  EXPECT_EQ(b.sent(0x185).size(), 1u);
  b.nmt(0x02);  // stop
  b.node().pdo().raise_event(1, b.now());
  b.sync();
  b.bus().run_for(ms(50));
  EXPECT_TRUE(b.sent(0x185).empty());
  EXPECT_TRUE(b.sent(0x285).empty());
  b.nmt(0x80);  // pre-operational
  b.sync();
  b.bus().run_for(ms(50));
  EXPECT_TRUE(b.sent(0x185).empty());
  EXPECT_TRUE(b.sent(0x285).empty());
}

TEST(Tpdo, EventTimerStartsOnePeriodAfterEnteringOperational) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1800, 5, 100), SdoAbort::kNone);
  b.start();
  const TimeUs t0 = b.now();
  b.bus().run_for(ms(250));
  auto frames = b.sent(0x185);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].time, t0 + ms(100));
  EXPECT_EQ(frames[1].time, t0 + ms(200));
}

TEST(Tpdo, SendOnStartOptionSendsAtOnceThenPeriodically) {
  PdoBus b("{tpdo_send_on_start: true}");
  ASSERT_EQ(b.write(0x1800, 5, 100), SdoAbort::kNone);
  b.start();
  const TimeUs t0 = b.now();
  b.bus().run_for(ms(150));
  auto frames = b.sent(0x185);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].time, t0);
  EXPECT_EQ(frames[0].frame, kTpdo1);
  EXPECT_EQ(frames[1].time, t0 + ms(100));
}

TEST(Tpdo, ApplicationEventRestartsTheEventTimer) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1800, 5, 100), SdoAbort::kNone);
  b.start();
  const TimeUs t0 = b.now();
  b.bus().run_for(ms(30));
  b.set(0x2000, 0, 0xAABBCCDD);
  b.node().pdo().raise_event(1, b.now());
  b.bus().run_for(ms(199));
  auto frames = b.sent(0x185);
  ASSERT_EQ(frames.size(), 2u);  // t0+30 (event), t0+130 (timer); t0+230 is next
  EXPECT_EQ(frames[0].time, t0 + ms(30));
  EXPECT_EQ(frames[0].frame, F(0x185, {0xDD, 0xCC, 0xBB, 0xAA, 0x66, 0x55}));
  EXPECT_EQ(frames[1].time, t0 + ms(130));
}

TEST(Tpdo, InhibitTimeDelaysEventsWithoutLosingThem) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1800, 3, 50), SdoAbort::kInvalidValue);  // PDO exists
  ASSERT_EQ(b.write(0x1800, 1, 0x80000185), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1800, 3, 50), SdoAbort::kNone);  // 5 ms
  ASSERT_EQ(b.write(0x1800, 1, 0x185), SdoAbort::kNone);
  b.start();
  const TimeUs t0 = b.now();
  b.node().pdo().raise_event(1, t0);
  b.bus().run_for(ms(1));
  b.set(0x2001, 0, 0x0102);
  b.node().pdo().raise_event(1, b.now());  // inside the inhibit time
  b.bus().run_for(ms(1));
  b.node().pdo().raise_event(1, b.now());  // merged with the pending one
  b.bus().run_for(ms(20));
  auto frames = b.sent(0x185);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].time, t0);
  EXPECT_EQ(frames[0].frame, kTpdo1);
  EXPECT_EQ(frames[1].time, t0 + ms(5));
  EXPECT_EQ(frames[1].frame, F(0x185, {0x44, 0x33, 0x22, 0x11, 0x02, 0x01}));
}

TEST(Tpdo, EventWithoutTimeGoesOutAtTheNextAdvance) {
  PdoBus b;
  b.start();
  const TimeUs t0 = b.now();
  b.node().pdo().raise_event(1);
  EXPECT_LE(b.node().next_deadline(), t0);
  b.bus().run_for(ms(1));
  auto frames = b.sent(0x185);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].time, t0);
}

TEST(Tpdo, RaiseEventForAnEntryHitsEveryEventDrivenTpdoMappingIt) {
  PdoBus b;
  // TPDO2: acyclic synchronous (type 0), mapping 0x2003.
  ASSERT_EQ(b.write(0x1801, 2, 0), SdoAbort::kNone);
  b.start();
  const OdEntry& mapped_by_2 = *b.node().od().find(0x2003, 0);
  const OdEntry& mapped_by_1 = *b.node().od().find(0x2001, 0);
  const OdEntry& unmapped = *b.node().od().find(0x2002, 0);
  b.node().pdo().raise_event_for(unmapped);
  b.bus().run_for(ms(1));
  EXPECT_TRUE(b.bus().take().empty());
  b.node().pdo().raise_event_for(mapped_by_1);
  b.node().pdo().raise_event_for(mapped_by_2);
  b.bus().run_for(ms(1));
  auto frames = b.bus().take();
  ASSERT_EQ(frames.size(), 1u);  // TPDO2 waits for SYNC
  EXPECT_EQ(frames[0].frame, kTpdo1);
  b.sync();
  EXPECT_EQ(b.sent(0x285).size(), 1u);
}

TEST(Tpdo, Type0SendsAtTheNextSyncAfterAnEventOnly) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1801, 2, 0), SdoAbort::kNone);
  b.start();
  b.sync();
  EXPECT_TRUE(b.sent(0x285).empty());
  b.node().pdo().raise_event(2, b.now());
  b.bus().run_for(ms(3));
  EXPECT_TRUE(b.sent(0x285).empty());
  const TimeUs ts = b.now();
  b.sync();
  auto frames = b.sent(0x285);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].time, ts);
  EXPECT_EQ(frames[0].frame, kTpdo2);
  b.sync();
  EXPECT_TRUE(b.sent(0x285).empty());
}

TEST(Tpdo, CyclicTypeSendsEveryNthSync) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1801, 2, 3), SdoAbort::kNone);
  b.start();
  std::vector<int> sent_at;
  for (int i = 1; i <= 9; ++i) {
    b.bus().run_for(ms(1));
    b.sync();
    if (!b.sent(0x285).empty()) sent_at.push_back(i);
  }
  EXPECT_EQ(sent_at, (std::vector<int>{3, 6, 9}));
}

TEST(Tpdo, Type1SamplesAtEverySync) {
  PdoBus b;
  b.start();
  b.sync();
  b.set(0x2003, 0, 0x99);
  b.sync();
  auto frames = b.sent(0x285);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].frame, kTpdo2);
  EXPECT_EQ(frames[1].frame, F(0x285, {0x99}));
}

TEST(Tpdo, SyncStartValueDelaysTheFirstTransmission) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1019, 0, 5), SdoAbort::kNone);          // SYNC with counter 1..5
  ASSERT_EQ(b.write(0x1801, 6, 3), SdoAbort::kInvalidValue);  // PDO exists
  ASSERT_EQ(b.write(0x1801, 1, 0x80000285), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1801, 6, 241), SdoAbort::kInvalidValue);
  ASSERT_EQ(b.write(0x1801, 6, 3), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1801, 2, 2), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1801, 1, 0x285), SdoAbort::kNone);
  b.start();
  // Counters 4 5 1 2 3 4 5 1 2: first at counter 3 (5th SYNC), then every 2nd.
  const std::uint8_t counters[] = {4, 5, 1, 2, 3, 4, 5, 1, 2};
  std::vector<int> sent_at;
  for (int i = 0; i < 9; ++i) {
    b.sync(counters[i]);
    if (!b.sent(0x285).empty()) sent_at.push_back(i + 1);
  }
  EXPECT_EQ(sent_at, (std::vector<int>{5, 7, 9}));
}

TEST(Tpdo, SyncStartValueIgnoredWhenSyncHasNoCounter) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1801, 1, 0x80000285), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1801, 6, 3), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1801, 1, 0x285), SdoAbort::kNone);
  b.start();
  b.sync();
  EXPECT_EQ(b.sent(0x285).size(), 1u);
}

TEST(Tpdo, Type252SendsTheSyncSampleOnRtr) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1801, 2, 252), SdoAbort::kNone);
  b.start();
  b.bus().inject(CanFrame::remote(0x285));
  EXPECT_TRUE(b.sent(0x285).empty());  // nothing sampled yet
  b.sync();
  EXPECT_TRUE(b.sent(0x285).empty());  // sampled, not sent
  b.set(0x2003, 0, 0x42);
  b.bus().run_for(ms(2));
  const TimeUs tr = b.now();
  b.bus().inject(CanFrame::remote(0x285, 1));
  auto frames = b.sent(0x285);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].time, tr);
  EXPECT_EQ(frames[0].frame, kTpdo2);  // value at the SYNC, not 0x42
  b.sync();
  b.bus().inject(CanFrame::remote(0x285, 1));
  frames = b.sent(0x285);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].frame, F(0x285, {0x42}));
}

TEST(Tpdo, Type253SamplesAndSendsOnRtrInOperationalOnly) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1801, 2, 253), SdoAbort::kNone);
  b.bus().inject(CanFrame::remote(0x285));
  EXPECT_TRUE(b.sent(0x285).empty());  // pre-operational
  b.start();
  b.sync();
  EXPECT_TRUE(b.sent(0x285).empty());
  b.set(0x2003, 0, 0x17);
  b.bus().inject(CanFrame::remote(0x285));
  auto frames = b.sent(0x285);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].frame, F(0x285, {0x17}));
}

TEST(Tpdo, RtrRefusedWhenCobIdBit30IsSet) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1801, 2, 253), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1801, 1, 0x40000285), SdoAbort::kNone);  // bit 30 may change while valid
  b.start();
  b.bus().inject(CanFrame::remote(0x285));
  EXPECT_TRUE(b.sent(0x285).empty());
  // And a type needing RTR cannot be chosen while RTR is off.
  ASSERT_EQ(b.write(0x1801, 2, 255), SdoAbort::kNone);
  EXPECT_EQ(b.write(0x1801, 2, 252), SdoAbort::kInvalidValue);
  EXPECT_EQ(b.write(0x1801, 2, 253), SdoAbort::kInvalidValue);
}

TEST(Tpdo, RtrOnAnEventDrivenTpdoAnswersWithFreshData) {
  PdoBus b;
  b.start();
  b.bus().inject(CanFrame::remote(0x185, 6));
  auto frames = b.sent(0x185);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].frame, kTpdo1);
}

TEST(Tpdo, RtrIgnoredWhenTheDeviceHasNoRtr) {
  PdoBus b("{tpdo_rtr_supported: false, tpdo_cobid_no_rtr_forced: true}");
  EXPECT_EQ(b.value(0x1800, 1), 0x185u);  // default as the profile says
  ASSERT_EQ(b.write(0x1800, 1, 0x80000185), SdoAbort::kNone);
  EXPECT_EQ(b.value(0x1800, 1), 0xC0000185u);  // bit 30 reads 1
  ASSERT_EQ(b.write(0x1800, 1, 0x185), SdoAbort::kNone);
  b.start();
  b.bus().inject(CanFrame::remote(0x185));
  EXPECT_TRUE(b.sent(0x185).empty());
}

TEST(Tpdo, DlcAlwaysEightPadsWithZeros) {
  PdoBus b("{tpdo_dlc_always_8: true}");
  b.start();
  b.sync();
  auto frames = b.sent(0x285);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].frame, F(0x285, {0x88, 0, 0, 0, 0, 0, 0, 0}));
}

TEST(Tpdo, Type0PacedByEventTimerOption) {
  PdoBus b("{tpdo_type0_paced_by_event_timer: true}");
  ASSERT_EQ(b.write(0x1801, 2, 0), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1801, 5, 5), SdoAbort::kNone);
  b.start();
  std::vector<int> sent_at;
  for (int i = 1; i <= 12; ++i) {
    b.sync();
    if (!b.sent(0x285).empty()) sent_at.push_back(i);
    b.bus().run_for(ms(1));
  }
  EXPECT_EQ(sent_at, (std::vector<int>{1, 6, 11}));
}

TEST(Tpdo, TwentyNineBitCobIdSendsExtendedFrames) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1801, 1, 0x80000285), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1801, 1, 0x20012345), SdoAbort::kNone);
  b.start();
  b.sync();
  auto frames = b.bus().take();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].frame.id, 0x12345u);
  EXPECT_TRUE(frames[0].frame.extended());
}

TEST(Tpdo, BitGranularMappingPacksLsbFirst) {
  PdoBus b;
  // TPDO2: BOOLEAN as 1 bit, then U16 at bit offset 1.
  ASSERT_EQ(b.write(0x1801, 1, 0x80000285), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1A01, 0, 0), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1A01, 1, 0x20040001), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1A01, 2, 0x20010010), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1A01, 0, 2), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1801, 1, 0x285), SdoAbort::kNone);
  b.set(0x2004, 0, 1);
  b.set(0x2001, 0, 0x8001);
  b.start();
  b.sync();
  auto frames = b.sent(0x285);
  ASSERT_EQ(frames.size(), 1u);
  // 1 | 0x8001 << 1 = 0x10003 over 17 bits -> 3 bytes.
  EXPECT_EQ(frames[0].frame, F(0x285, {0x03, 0x00, 0x01}));
}

}  // namespace
}  // namespace cansim::pdo_test

namespace cansim::pdo_test {
namespace {

// The reference profile as shipped: TPDO1 event-driven 100 ms, TPDO2 every
// SYNC, TPDO3 RTR-only, TPDO4 invalid.
TEST(TpdoGeneric404, ReferenceProfileTransmits) {
  config::Profile p = test::load_repo_profile("generic-404");
  test::SimBus bus;
  Node& n = bus.add(p, 0x10).node();
  bus.power_on_all();
  bus.run_for(ms(10));
  bus.inject(F(0x000, {0x01, 0x10}));
  const TimeUs t0 = bus.now();
  bus.run_for(ms(100));
  bus.inject(F(0x080, {}));
  bus.inject(CanFrame::remote(0x390));
  bus.inject(CanFrame::remote(0x490));  // TPDO4 invalid: no answer
  std::vector<Sent> pdos;
  for (const Sent& s : bus.take())
    if (s.frame.id >= 0x180 && s.frame.id < 0x500) pdos.push_back(s);
  ASSERT_EQ(pdos.size(), 3u) << test::to_string(pdos);
  EXPECT_EQ(pdos[0].time, t0 + ms(100));
  EXPECT_EQ(pdos[0].frame.id, 0x190u);
  EXPECT_EQ(pdos[0].frame.dlc, 5);
  EXPECT_EQ(pdos[1].frame.id, 0x290u);
  EXPECT_EQ(pdos[1].frame.dlc, 4);
  EXPECT_EQ(pdos[2].frame.id, 0x390u);
  EXPECT_EQ(pdos[2].frame.dlc, 4);
  EXPECT_EQ(n.pdo().tpdo_count(), 4u);
  EXPECT_EQ(n.pdo().rpdo_count(), 1u);
}

}  // namespace
}  // namespace cansim::pdo_test
