// EMCY producer, error register and pre-defined error field (CiA 301 §7.2.7,
// §7.5.2.2-4, §7.5.2.17-18).
#include "nmt_support.hpp"

namespace cansim::nmt_test {
namespace {

class EmcyTest : public Harness {
 protected:
  SimNode& start(const std::string& options = "{}") {
    SimNode& n = add(5, options);
    bus.power_on_all();
    take();
    return n;
  }
};

const std::uint8_t kMfr[5] = {0x55, 0xC5, 0x03, 0x04, 0x05};

TEST_F(EmcyTest, RaiseSendsFrameRecordsHistoryAndRegister) {
  SimNode& n = start();
  bus.run_until(ms(5));
  n->emcy().raise(0x5030, 0, kMfr, now());
  EXPECT_EQ(take(), S({{ms(5), F(0x85, {0x30, 0x50, 0x01, 0x55, 0xC5, 0x03, 0x04, 0x05})}}));
  EXPECT_EQ(rd(n, 0x1001, 0), 0x01u);
  EXPECT_EQ(rd(n, 0x1003, 0), 1u);
  EXPECT_EQ(rd(n, 0x1003, 1), 0xC5555030u);
  EXPECT_EQ(n->emcy().active_count(), 1u);
}

TEST_F(EmcyTest, ErrorRegisterBitsFromCodeClassesAndCaller) {
  SimNode& n = start();
  struct Case {
    std::uint16_t code;
    std::uint8_t bits;
    std::uint8_t reg;
  } cases[] = {{0x1000, 0, 0x01}, {0x2310, 0, 0x03},    {0x3120, 0, 0x05}, {0x4210, 0, 0x09},
               {0x5000, 0, 0x01}, {0x6100, 0, 0x01},    {0x8110, 0, 0x11}, {0x8210, 0, 0x11},
               {0xFF01, 0, 0x81}, {0x6300, 0x20, 0x21}, {0xF011, 0, 0x01}};
  for (const Case& c : cases) {
    n->emcy().raise(c.code, c.bits, now());
    EXPECT_EQ(rd(n, 0x1001, 0), c.reg) << std::hex << c.code;
    n->emcy().clear(c.code, now());
    EXPECT_EQ(rd(n, 0x1001, 0), 0u);
  }
  n->emcy().raise(0x2310, 0, now());
  n->emcy().raise(0x4210, 0, now());
  EXPECT_EQ(rd(n, 0x1001, 0), 0x0Bu);
  n->emcy().clear(0x2310, now());
  EXPECT_EQ(rd(n, 0x1001, 0), 0x09u);
}

TEST_F(EmcyTest, VendorRegisterModes) {
  SimNode& n = start("{emcy_register_generic_bit: false, emcy_register_class_bits: false}");
  n->emcy().raise(0x8120, 0x88, now());
  n->emcy().raise(0x8130, 0, now());
  EXPECT_EQ(take(),
            S({{0, F(0x85, {0x20, 0x81, 0x88, 0, 0, 0, 0, 0})}, {0, F(0x85, {0x30, 0x81, 0x88, 0, 0, 0, 0, 0})}}));
}

TEST_F(EmcyTest, ErrorResetWhenTheLastErrorClears) {
  SimNode& n = start();
  n->emcy().raise(0x2310, 0, now());
  n->emcy().raise(0x4210, 0, now());
  take();
  n->emcy().clear(0x2310, now());  // partial: error reset with remaining register
  n->emcy().clear(0x9999, now());  // not active: nothing
  n->emcy().clear(0x4210, now());
  EXPECT_EQ(take(), S({{0, F(0x85, {0, 0, 0x09, 0, 0, 0, 0, 0})}, {0, F(0x85, {0, 0, 0x00, 0, 0, 0, 0, 0})}}));
  EXPECT_EQ(rd(n, 0x1003, 0), 2u);  // error resets are not recorded
  EXPECT_EQ(n->emcy().active_count(), 0u);
}

TEST_F(EmcyTest, PartialClearOptions) {
  SimNode& n = start("{emcy_on_partial_clear: latest}");
  n->emcy().raise(0x2310, 0, now());
  n->emcy().raise(0x4210, 0, now());
  n->emcy().raise(0x3120, 0, now());
  take();
  n->emcy().clear(0x3120, now());
  EXPECT_EQ(take(), S({{0, F(0x85, {0x10, 0x42, 0x0B, 0, 0, 0, 0, 0})}}));
  SimNode& m = add(6, "{emcy_on_partial_clear: none}");
  m->power_on(now());
  take();
  m->emcy().raise(0x2310, 0, now());
  m->emcy().raise(0x4210, 0, now());
  m->emcy().clear(0x2310, now());
  m->emcy().clear_all(now());
  EXPECT_EQ(take(), S({{0, F(0x86, {0x10, 0x23, 0x03, 0, 0, 0, 0, 0})},
                       {0, F(0x86, {0x10, 0x42, 0x0B, 0, 0, 0, 0, 0})},
                       {0, F(0x86, {0, 0, 0, 0, 0, 0, 0, 0})}}));
}

TEST_F(EmcyTest, HistoryOrderDepthAndClear) {
  SimNode& n = start();
  for (std::uint16_t code : {0x1001, 0x1002, 0x1003, 0x1004, 0x1005}) n->emcy().report(code, 0, nullptr, now());
  EXPECT_EQ(rd(n, 0x1003, 0), 4u);  // depth = 4 subs
  EXPECT_EQ(rd(n, 0x1003, 1), 0x1005u);
  EXPECT_EQ(rd(n, 0x1003, 2), 0x1004u);
  EXPECT_EQ(rd(n, 0x1003, 3), 0x1003u);
  EXPECT_EQ(rd(n, 0x1003, 4), 0x1002u);
  EXPECT_EQ(wr8(n, 0x1003, 0, 1), SdoAbort::kInvalidValue);
  EXPECT_EQ(wr32(n, 0x1003, 1, 0), SdoAbort::kReadOnly);
  EXPECT_EQ(wr8(n, 0x1003, 0, 0), SdoAbort::kNone);
  EXPECT_EQ(rd(n, 0x1003, 0), 0u);
  SdoAbort why = SdoAbort::kNone;
  rd(n, 0x1003, 1, &why);
  EXPECT_EQ(why, SdoAbort::kNoData);
  n->emcy().report(0x1006, 0, nullptr, now());
  EXPECT_EQ(rd(n, 0x1003, 1, &why), 0x1006u);
  rd(n, 0x1003, 2, &why);
  EXPECT_EQ(why, SdoAbort::kNoData);
}

TEST_F(EmcyTest, HistoryVendorOptions) {
  SimNode& n = start(
      "{emcy_history_bad_write_abort: 0x06090031, emcy_history_read_empty_abort: 0, "
      "emcy_history_register_in_info: true}");
  EXPECT_EQ(wr8(n, 0x1003, 0, 2), SdoAbort::kValueTooHigh);
  SdoAbort why = SdoAbort::kNone;
  EXPECT_EQ(rd(n, 0x1003, 3, &why), 0u);
  EXPECT_EQ(why, SdoAbort::kNone);
  n->emcy().raise(0x4210, 0, kMfr, now());
  EXPECT_EQ(rd(n, 0x1003, 1), 0x00094210u);
}

TEST_F(EmcyTest, InhibitTimeQueuesAndSendsWhenItExpires) {
  SimNode& n = start();
  ASSERT_EQ(wr16(n, 0x1015, 0, 100), SdoAbort::kNone);  // 10 ms
  bus.run_until(ms(1));
  n->emcy().raise(0x2310, 0, now());
  bus.run_until(ms(3));
  n->emcy().raise(0x3120, 0, now());
  n->emcy().clear(0x2310, now());
  bus.run_until(ms(100));
  EXPECT_EQ(take(), S({{ms(1), F(0x85, {0x10, 0x23, 0x03, 0, 0, 0, 0, 0})},
                       {ms(11), F(0x85, {0x20, 0x31, 0x07, 0, 0, 0, 0, 0})},
                       {ms(21), F(0x85, {0x00, 0x00, 0x05, 0, 0, 0, 0, 0})}}));
}

TEST_F(EmcyTest, InhibitRingDropsWhenFull) {
  SimNode& n = start();
  ASSERT_EQ(wr16(n, 0x1015, 0, 10), SdoAbort::kNone);  // 1 ms
  for (int i = 0; i < 12; ++i) n->emcy().report(std::uint16_t(0x1000 + i), 0, nullptr, now());
  bus.run_until(ms(50));
  auto log = bus.take();
  ASSERT_EQ(log.size(), 1u + Emcy::kQueueSize);
  for (std::size_t k = 0; k < log.size(); ++k) EXPECT_EQ(log[k].time, ms(1) * TimeUs(k));
  EXPECT_EQ(log.back().frame.data[0], 0x08);
}

TEST_F(EmcyTest, NotSentInStoppedButRecorded) {
  SimNode& n = start();
  nmt(0x02, 5);
  n->emcy().raise(0x4210, 0, now());
  EXPECT_EQ(take(), "");
  EXPECT_EQ(rd(n, 0x1001, 0), 0x09u);
  nmt(0x80, 5);
  SdoAbort why;
  EXPECT_EQ(rd(n, 0x1003, 1, &why), 0x4210u);
  EXPECT_EQ(take(), "");  // CiA 301: not sent later either
}

TEST_F(EmcyTest, ResendAfterStoppedOption) {
  SimNode& n = start("{emcy_resend_after_stopped: true}");
  nmt(0x02, 5);
  n->emcy().raise(0x4210, 0, now());
  n->emcy().raise(0x2310, 0, now());
  n->emcy().clear(0x2310, now());
  bus.run_until(ms(7));
  nmt(0x01, 5);
  EXPECT_EQ(take(), S({{ms(7), F(0x85, {0x10, 0x42, 0x09, 0, 0, 0, 0, 0})}}));
}

TEST_F(EmcyTest, RaisedBeforeBootUpGoesOutAfterIt) {
  struct BootError : Application {
    void on_reset(Node& n, ResetKind, TimeUs t) override { n.emcy().raise(0x6161, 0, t); }
  } app;
  add(5, "{boot_up_delay_ms: 20}", "", &app);
  bus.power_on_all();
  bus.run_until(ms(30));
  EXPECT_EQ(take(), S({{ms(20), F(0x705, {0x00})}, {ms(20), F(0x85, {0x61, 0x61, 0x01, 0, 0, 0, 0, 0})}}));
}

TEST_F(EmcyTest, CobIdRules) {
  SimNode& n = start();
  EXPECT_EQ(wr32(n, 0x1014, 0, 0x86), SdoAbort::kInvalidValue);        // valid: CAN-ID fixed
  EXPECT_EQ(wr32(n, 0x1014, 0, 0x40000085), SdoAbort::kInvalidValue);  // bit 30 reserved
  ASSERT_EQ(wr32(n, 0x1014, 0, 0x80000085), SdoAbort::kNone);          // invalid: no EMCY
  n->emcy().raise(0x1000, 0, now());
  EXPECT_EQ(take(), "");
  EXPECT_EQ(rd(n, 0x1003, 1), 0x1000u);
  EXPECT_EQ(wr32(n, 0x1014, 0, 0x80000800), SdoAbort::kInvalidValue);  // 11-bit overflow
  ASSERT_EQ(wr32(n, 0x1014, 0, 0x800000A0), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1014, 0, 0x000000A0), SdoAbort::kNone);
  n->emcy().clear(0x1000, now());
  ASSERT_EQ(wr32(n, 0x1014, 0, 0x80000000 | 0x20001234), SdoAbort::kNone);
  ASSERT_EQ(wr32(n, 0x1014, 0, 0x20001234), SdoAbort::kNone);
  n->emcy().report(0x1000, 0, nullptr, now());
  CanFrame ext = F(0x1234, {0x00, 0x10, 0x01, 0, 0, 0, 0, 0});
  ext.flags = CanFrame::kExtended;
  EXPECT_EQ(take(), S({{0, F(0xA0, {0, 0, 0, 0, 0, 0, 0, 0})}, {0, ext}}));
}

TEST_F(EmcyTest, ResetClearsActiveErrorsAndHistory) {
  SimNode& n = start();
  n->emcy().raise(0x4210, 0, now());
  nmt(0x82, 5);
  EXPECT_EQ(n->emcy().active_count(), 0u);
  EXPECT_EQ(rd(n, 0x1001, 0), 0u);
  EXPECT_EQ(rd(n, 0x1003, 0), 0u);
}

}  // namespace
}  // namespace cansim::nmt_test
