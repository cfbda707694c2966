// RPDO reception (CiA 301 §7.2.2): immediate vs SYNC actuation, NMT gating,
// length EMCYs 0x8210/0x8220, timeout EMCY 0x8250, dummy entries, hooks.
#include "unit/pdo_fixture.hpp"

namespace cansim::pdo_test {
namespace {

const CanFrame kRpdo = F(0x205, {0x01, 0x02, 0x03, 0x04, 0x05, 0x06});

// EMCY frames on 0x80+5 with their error code.
std::vector<std::pair<TimeUs, std::uint16_t>> emcys(PdoBus& b) {
  std::vector<std::pair<TimeUs, std::uint16_t>> out;
  for (const Sent& s : b.sent(0x85)) out.emplace_back(s.time, get_u16(s.frame.data));
  return out;
}

TEST(Rpdo, EventDrivenTypeWritesAtOnce) {
  PdoBus b;
  b.start();
  b.bus().inject(kRpdo);
  EXPECT_EQ(b.value(0x2000, 0), 0x04030201u);
  EXPECT_EQ(b.value(0x2001, 0), 0x0605u);
  EXPECT_TRUE(emcys(b).empty());
}

TEST(Rpdo, IgnoredOutsideOperational) {
  PdoBus b;
  b.bus().inject(kRpdo);  // pre-operational
  EXPECT_EQ(b.value(0x2000, 0), 0x11223344u);
  b.start();
  b.nmt(0x02);
  b.bus().inject(kRpdo);
  EXPECT_EQ(b.value(0x2000, 0), 0x11223344u);
}

TEST(Rpdo, IgnoredWhileInvalid) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1400, 1, 0x80000205), SdoAbort::kNone);
  b.start();
  b.bus().inject(kRpdo);
  EXPECT_EQ(b.value(0x2000, 0), 0x11223344u);
}

TEST(Rpdo, SynchronousTypesApplyAtTheNextSync) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1400, 2, 1), SdoAbort::kNone);
  b.start();
  b.bus().inject(kRpdo);
  EXPECT_EQ(b.value(0x2000, 0), 0x11223344u);
  b.bus().inject(F(0x205, {0x0A, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F}));  // the later one wins
  b.sync();
  EXPECT_EQ(b.value(0x2000, 0), 0x0D0C0B0Au);
  EXPECT_EQ(b.value(0x2001, 0), 0x0F0Eu);
  b.set(0x2000, 0, 0);
  b.sync();  // nothing new received: nothing applied
  EXPECT_EQ(b.value(0x2000, 0), 0u);
}

TEST(Rpdo, ShortFrameIsDroppedWithEmcy8210Once) {
  PdoBus b;
  b.start();
  const TimeUs t = b.now();
  b.bus().inject(F(0x205, {0x01, 0x02, 0x03, 0x04, 0x05}));
  b.bus().inject(F(0x205, {0x01}));
  EXPECT_EQ(b.value(0x2000, 0), 0x11223344u);
  auto e = emcys(b);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], std::make_pair(t, std::uint16_t(0x8210)));
  b.bus().inject(kRpdo);  // a good one ends the episode (error reset EMCY 0x0000)
  EXPECT_EQ(b.value(0x2000, 0), 0x04030201u);
  e = emcys(b);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].second, 0x0000);
}

TEST(Rpdo, LongFrameIsUsedWithEmcy8220) {
  PdoBus b;
  b.start();
  const TimeUs t = b.now();
  b.bus().inject(F(0x205, {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08}));
  EXPECT_EQ(b.value(0x2000, 0), 0x04030201u);
  EXPECT_EQ(b.value(0x2001, 0), 0x0605u);
  auto e = emcys(b);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], std::make_pair(t, std::uint16_t(0x8220)));
}

TEST(Rpdo, LongFrameWithoutEmcyOption) {
  PdoBus b("{rpdo_length_exceeded_emcy: false}");
  b.start();
  b.bus().inject(F(0x205, {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07}));
  EXPECT_EQ(b.value(0x2000, 0), 0x04030201u);
  EXPECT_TRUE(emcys(b).empty());
}

TEST(Rpdo, TimeoutEmcy8250OnceAfterTheLastReception) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1400, 5, 50), SdoAbort::kNone);
  b.start();
  b.bus().run_for(ms(200));
  EXPECT_TRUE(emcys(b).empty());  // monitoring starts with the first RPDO
  b.bus().inject(kRpdo);
  const TimeUs t1 = b.now();
  b.bus().run_for(ms(30));
  b.bus().inject(kRpdo);  // restarts the timeout
  const TimeUs t2 = b.now();
  ASSERT_EQ(t2, t1 + ms(30));
  b.bus().run_for(ms(300));
  auto e = emcys(b);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], std::make_pair(t2 + ms(50), std::uint16_t(0x8250)));
}

TEST(Rpdo, DummyEntriesSkipBits) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1400, 1, 0x80000205), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1600, 0, 0), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1600, 1, 0x00050008), SdoAbort::kNone);  // skip one byte
  ASSERT_EQ(b.write(0x1600, 2, 0x20010010), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1600, 0, 2), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1400, 1, 0x205), SdoAbort::kNone);
  b.start();
  b.bus().inject(F(0x205, {0xEE, 0x34, 0x12}));
  EXPECT_EQ(b.value(0x2001, 0), 0x1234u);
  EXPECT_EQ(b.value(0x2000, 0), 0x11223344u);
}

TEST(Rpdo, TwentyNineBitCobId) {
  PdoBus b;
  ASSERT_EQ(b.write(0x1400, 1, 0x80000205), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1400, 1, 0x20000205), SdoAbort::kNone);
  b.start();
  b.bus().inject(kRpdo);  // 11-bit 0x205 is someone else
  EXPECT_EQ(b.value(0x2000, 0), 0x11223344u);
  CanFrame ext = kRpdo;
  ext.flags = CanFrame::kExtended;
  b.bus().inject(ext);
  EXPECT_EQ(b.value(0x2000, 0), 0x04030201u);
}

class RecordingApp : public Application {
 public:
  SdoAbort check_write(Node&, const OdEntry& e, std::span<const std::uint8_t> d, TimeUs) override {
    return e.index == 0x2007 && d[0] == 0xFF ? SdoAbort::kInvalidValue : SdoAbort::kNone;
  }
  void after_write(Node& n, const OdEntry& e, TimeUs now) override {
    writes.emplace_back(now, std::uint8_t(n.values().get_u(e)));
  }
  std::vector<std::pair<TimeUs, std::uint8_t>> writes;
};

TEST(Rpdo, WriteHooksRunForHookedEntries) {
  RecordingApp app;
  PdoBus b("{}", &app);
  ASSERT_EQ(b.write(0x1400, 1, 0x80000205), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1600, 0, 0), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1600, 1, 0x20070008), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1600, 0, 1), SdoAbort::kNone);
  ASSERT_EQ(b.write(0x1400, 1, 0x205), SdoAbort::kNone);
  b.start();
  const TimeUs t = b.now();
  b.bus().inject(F(0x205, {0x12}));
  b.bus().inject(F(0x205, {0xFF}));  // refused by the application: value kept
  EXPECT_EQ(b.value(0x2007, 0), 0x12u);
  ASSERT_EQ(app.writes.size(), 1u);
  EXPECT_EQ(app.writes[0], std::make_pair(t, std::uint8_t(0x12)));
}

}  // namespace
}  // namespace cansim::pdo_test
