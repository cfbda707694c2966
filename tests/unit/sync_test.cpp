// SYNC consumer: 0x1005, 0x1007, 0x1019 (CiA 301 §7.2.5, §7.5.2.5-7, 40).
#include <algorithm>

#include "nmt_support.hpp"

namespace cansim::nmt_test {
namespace {

struct SyncRecorder : Application {
  std::string log;
  void on_sync(Node&, std::uint8_t counter, TimeUs t) override {
    log += std::to_string(counter) + "@" + std::to_string(t) + " ";
  }
};

class Sync : public Harness {
 protected:
  SimNode& start(const std::string& options = "{}") {
    SimNode& n = add(5, options, "", &app);
    bus.power_on_all();
    take();
    return n;
  }
  SyncRecorder app;
};

TEST_F(Sync, ConsumedInPreOperationalAndOperationalNotStopped) {
  start();
  inject(F(0x80, {}));
  nmt(0x01, 5);
  bus.run_until(ms(1));
  inject(F(0x80, {}));
  nmt(0x02, 5);
  bus.run_until(ms(2));
  inject(F(0x80, {}));
  EXPECT_EQ(app.log, "0@0 0@1000 ");
  EXPECT_EQ(take(), "");
}

TEST_F(Sync, WrongLengthRaisesEmcy8240AndIsIgnored) {
  SimNode& n = start();
  inject(F(0x80, {0x01}));
  EXPECT_EQ(app.log, "");
  EXPECT_EQ(take(), S({{0, F(0x85, {0x40, 0x82, 0x11, 0x01, 0, 0, 0, 0})}}));
  EXPECT_EQ(rd(n, 0x1003, 1), 0x00018240u);
  EXPECT_EQ(rd(n, 0x1001, 0), 0u);  // one-shot event, nothing stays active
  inject(F(0x80, {}));
  EXPECT_EQ(app.log, "0@0 ");
  EXPECT_EQ(take(), "");
}

TEST_F(Sync, CounterWithOverflowValue) {
  SimNode& n = start();
  ASSERT_EQ(wr8(n, 0x1019, 0, 3), SdoAbort::kNone);
  inject(F(0x80, {1}));
  inject(F(0x80, {2}));
  inject(F(0x80, {3}));
  inject(F(0x80, {1}));
  EXPECT_EQ(app.log, "1@0 2@0 3@0 1@0 ");
  inject(F(0x80, {}));  // DLC 0 while a counter is expected
  EXPECT_EQ(take(), S({{0, F(0x85, {0x40, 0x82, 0x11, 0x00, 0, 0, 0, 0})}}));
  inject(F(0x80, {1, 2}));
  EXPECT_EQ(take(), S({{0, F(0x85, {0x40, 0x82, 0x11, 0x02, 0, 0, 0, 0})}}));
  EXPECT_EQ(app.log, "1@0 2@0 3@0 1@0 ");
}

TEST_F(Sync, AnyLengthOption) {
  start("{sync_accept_any_dlc: true}");
  inject(F(0x80, {7}));
  inject(F(0x80, {}));
  EXPECT_EQ(app.log, "0@0 0@0 ");
  EXPECT_EQ(take(), "");
}

TEST_F(Sync, OverflowValueRules) {
  SimNode& n = start();
  EXPECT_EQ(wr8(n, 0x1019, 0, 1), SdoAbort::kInvalidValue);
  EXPECT_EQ(wr8(n, 0x1019, 0, 241), SdoAbort::kInvalidValue);
  EXPECT_EQ(wr8(n, 0x1019, 0, 255), SdoAbort::kInvalidValue);
  EXPECT_EQ(wr8(n, 0x1019, 0, 2), SdoAbort::kNone);
  EXPECT_EQ(wr8(n, 0x1019, 0, 240), SdoAbort::kNone);
  EXPECT_EQ(wr8(n, 0x1019, 0, 0), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1006, 0, 10000), SdoAbort::kNone);
  EXPECT_EQ(wr8(n, 0x1019, 0, 5), SdoAbort::kDeviceState);
  EXPECT_EQ(rd(n, 0x1019, 0), 0u);
}

TEST_F(Sync, CobIdChangeAndGenerateBit) {
  SimNode& n = start();
  EXPECT_EQ(wr32(n, 0x1005, 0, 0x40000080), SdoAbort::kInvalidValue);
  EXPECT_EQ(wr32(n, 0x1005, 0, 0x00000880), SdoAbort::kInvalidValue);  // 11-bit with bit 11
  std::uint32_t epoch = n->rx_epoch();
  ASSERT_EQ(wr32(n, 0x1005, 0, 0x81), SdoAbort::kNone);
  EXPECT_NE(n->rx_epoch(), epoch);
  std::vector<std::uint32_t> ids;
  n->collect_rx_ids(ids);
  EXPECT_NE(std::find(ids.begin(), ids.end(), 0x81u), ids.end());
  EXPECT_EQ(std::find(ids.begin(), ids.end(), 0x80u), ids.end());
  inject(F(0x80, {}));
  inject(F(0x81, {}));
  EXPECT_EQ(app.log, "0@0 ");
  ASSERT_EQ(wr32(n, 0x1005, 0, 0x20012345), SdoAbort::kNone);  // 29-bit
  CanFrame ext = F(0x12345, {});
  ext.flags = CanFrame::kExtended;
  inject(ext);
  inject(F(0x345, {}));
  EXPECT_EQ(app.log, "0@0 0@0 ");
}

TEST_F(Sync, GenerateBitAcceptedWhenTheProfileSaysSo) {
  SimNode& n = start("{sync_generate_bit_abort: 0}");
  EXPECT_EQ(wr32(n, 0x1005, 0, 0x40000080), SdoAbort::kNone);
  inject(F(0x80, {}));
  EXPECT_EQ(app.log, "0@0 ");
  SimNode& m = add(6, "{sync_generate_bit_abort: 0x06090031}");
  m->power_on(now());
  EXPECT_EQ(wr32(m, 0x1005, 0, 0x40000080), SdoAbort::kValueTooHigh);
}

TEST_F(Sync, WindowOpensAtEachSync) {
  SimNode& n = start();
  EXPECT_TRUE(n->sync().window_open(now()));  // 0x1007 = 0: no window
  ASSERT_EQ(wr32(n, 0x1007, 0, 5000), SdoAbort::kNone);
  EXPECT_FALSE(n->sync().window_open(now()));  // no SYNC yet
  bus.run_until(ms(10));
  inject(F(0x80, {}));
  EXPECT_TRUE(n->sync().window_open(ms(10)));
  EXPECT_TRUE(n->sync().window_open(ms(15)));
  EXPECT_FALSE(n->sync().window_open(ms(15) + 1));
}

}  // namespace
}  // namespace cansim::nmt_test
