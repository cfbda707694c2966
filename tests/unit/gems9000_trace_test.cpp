// Gems 9000: every frame trace of the spec (gems-9000.md §10, the manual's
// figures) replayed on a SimBus against profiles/gems9000.yaml, node 1.
// Frames in, exact frames out, answered at once (within 5 ms: "a single CAN
// frame ... followed by a single CAN frame containing the 9000 response").
// Where the manual prints a wrong byte the resolved behaviour is asserted and
// the comment names the spec §11 item.
#include <gtest/gtest.h>

#include "gems9000_support.hpp"

namespace cansim::test {
namespace {

class Trace : public GemsFixture {
 protected:
  // rx frame in, the frames the node answers within 5 ms out (at most 5 ms late).
  std::vector<CanFrame> rx(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
    const TimeUs t0 = bus.now();
    master(id, bytes);
    bus.run_for(ms(5));
    std::vector<CanFrame> out;
    for (const Sent& s : bus.take()) {
      EXPECT_LT(s.time - t0, ms(5)) << to_string(s.frame);
      out.push_back(s.frame);
    }
    return out;
  }
  std::vector<CanFrame> lss(std::initializer_list<std::uint8_t> bytes) { return rx(0x7E5, bytes); }
  std::vector<CanFrame> sync_rx() { return rx(0x080, {}); }
  void enter_lss_configuration() {
    boot();
    EXPECT_TRUE(rx(0x000, {0x02, 0x01}).empty());
    EXPECT_TRUE(lss({0x04, 0x01, 0, 0, 0, 0, 0, 0}).empty());
    ASSERT_TRUE(node().lss().configuring());
  }
};

// Figs. 1 and 13: boot-up of node 1 after excitation, DLC 1, then pre-operational.
TEST_F(Trace, Fig01And13BootUp) {
  bus.power_on_all();
  bus.run_for(ms(5));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x701, {0x00}));
  EXPECT_EQ(out[0].frame.dlc, 1);
  EXPECT_EQ(out[0].time, 0);
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
}

// Fig. 2 (printed "ID 02 / 01", spec §11 #2): NMT stop 000 [02 01].
TEST_F(Trace, Fig02StopBeforeLss) {
  boot();
  EXPECT_TRUE(rx(0x000, {0x02, 0x01}).empty());
  EXPECT_EQ(node().state(), NmtState::kStopped);
}

// Fig. 3: switch mode global to configuration, no answer. LSS frames are DLC 8
// (CiA 305; the manual prints only the significant bytes).
TEST_F(Trace, Fig03SwitchModeGlobalConfiguration) { enter_lss_configuration(); }

// Figs. 4/5: the manual's layout "13 04" (index in byte 1, spec §11 #3); the
// answer in CiA 305 framing [13 err ...] (printed "[0 0]", spec §11 #4).
TEST_F(Trace, Fig04And05ConfigureBitTiming125k) {
  enter_lss_configuration();
  EXPECT_EQ(lss({0x13, 0x04, 0, 0, 0, 0, 0, 0}), one(0x7E4, {0x13, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(node().lss().pending_bit_rate_index(), 4);
}

// Fig. 6: activate, 1000 ms switch delay used twice: the new rate after the
// first delay, no frame until the second one has expired. Figs. 7/8: store,
// sent at the new rate, answered [17 00] (error 0). Fig. 9: back to operation.
TEST_F(Trace, Fig06To09ActivateStoreAndLeave) {
  enter_lss_configuration();
  ASSERT_EQ(lss({0x13, 0x04, 0, 0, 0, 0, 0, 0}).size(), 1u);
  ASSERT_TRUE(node().heartbeat().producer_time_ms() == 0);
  EXPECT_TRUE(lss({0x15, 0xE8, 0x03, 0, 0, 0, 0, 0}).empty());
  const TimeUs t0 = bus.now() - ms(5);
  bus.run_until(t0 + ms(999));
  EXPECT_EQ(node().bit_rate_index(), 3);
  bus.run_until(t0 + ms(1001));
  EXPECT_EQ(node().bit_rate_index(), 4);
  node().set_bus_bit_rate(4);  // the master follows to 125 kbit/s
  bus.run_until(t0 + ms(2001));
  EXPECT_TRUE(bus.take().empty());
  EXPECT_EQ(lss({0x17, 0, 0, 0, 0, 0, 0, 0}), one(0x7E4, {0x17, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(node().store().stored_lss().bit_rate_index, 4);
  EXPECT_TRUE(lss({0x04, 0x00, 0, 0, 0, 0, 0, 0}).empty());
  EXPECT_FALSE(node().lss().configuring());
}

// Figs. 10/11: configure node-ID 0x0A. Command specifier printed "1" = 0x11,
// answer printed on 0x7E5 as "[0 0]": CiA 305 0x7E4 [11 00] (spec §11 #4).
TEST_F(Trace, Fig10And11ConfigureNodeId) {
  enter_lss_configuration();
  EXPECT_EQ(lss({0x11, 0x0A, 0, 0, 0, 0, 0, 0}), one(0x7E4, {0x11, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(node().lss().pending_node_id(), 0x0A);
}

// Fig. 14: start remote node, node-ID 00 = all nodes.
TEST_F(Trace, Fig14StartAll) {
  boot();
  EXPECT_TRUE(rx(0x000, {0x01, 0x00}).empty());
  EXPECT_EQ(node().state(), NmtState::kOperational);
}

// Figs. 15/16: stop, enter pre-operational.
TEST_F(Trace, Fig15And16StopAndPreOperational) {
  boot();
  EXPECT_TRUE(rx(0x000, {0x02, 0x01}).empty());
  EXPECT_EQ(node().state(), NmtState::kStopped);
  EXPECT_TRUE(rx(0x000, {0x80, 0x01}).empty());
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
}

// Fig. 17: reset node, then the boot-up.
TEST_F(Trace, Fig17ResetNode) {
  boot();
  EXPECT_EQ(rx(0x000, {0x81, 0x01}), one(0x701, {0x00}));
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
}

// Fig. 18 prints 0x81 (= reset node) for reset communication; the CiA 301
// command 0x82 is reset communication (spec §11 #1): boot-up, and only the
// communication area is reloaded.
TEST_F(Trace, Fig18ResetCommunication) {
  boot();
  ASSERT_TRUE(write_real(0x6124, 1, 10.0f));
  ASSERT_TRUE(write32(0x1017, 0, 1000));
  EXPECT_EQ(rx(0x000, {0x82, 0x01}), one(0x701, {0x00}));
  EXPECT_EQ(u(0x1017, 0), 0u);
  EXPECT_FLOAT_EQ(real(0x6124, 1), 10.0f);
  EXPECT_EQ(rx(0x000, {0x81, 0x01}), one(0x701, {0x00}));  // as printed: a reset node
  EXPECT_FLOAT_EQ(real(0x6124, 1), 0.0f);
}

// Fig. 19: the heartbeat byte per state (0 boot-up, 4, 5, 127).
TEST_F(Trace, Fig19HeartbeatStates) {
  boot();
  ASSERT_TRUE(write32(0x1017, 0, 100));
  EXPECT_EQ(frames_for(ms(100)), one(0x701, {0x7F}));
  nmt(0x01);
  EXPECT_EQ(frames_for(ms(100)), one(0x701, {0x05}));
  nmt(0x02);
  EXPECT_EQ(frames_for(ms(100)), one(0x701, {0x04}));
}

// Fig. 21: device type, answered 0x42 (size not indicated).
TEST_F(Trace, Fig21ReadDeviceType) {
  boot();
  EXPECT_EQ(rx(0x601, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}),
            one(0x581, {0x42, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
}

// Fig. 23: heartbeat 1000 ms written with 0x22.
TEST_F(Trace, Fig23WriteHeartbeat) {
  boot();
  EXPECT_EQ(rx(0x601, {0x22, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0}), confirmed(0x1017, 0));
  EXPECT_EQ(u(0x1017, 0), 1000u);
}

// Fig. 24: 1000:01 does not exist.
TEST_F(Trace, Fig24InvalidSubIndex) {
  boot();
  EXPECT_EQ(rx(0x601, {0x40, 0x00, 0x10, 0x01, 0, 0, 0, 0}),
            one(0x581, {0x80, 0x00, 0x10, 0x01, 0x11, 0x00, 0x09, 0x06}));
}

// Fig. 29: boot-up, start, two SYNCs each answered by the default PDO, DLC 8.
TEST_F(Trace, Fig29PressureReading) {
  bus.power_on_all();
  bus.run_for(ms(5));
  EXPECT_EQ(bus.take().at(0).frame, F(0x701, {0x00}));
  EXPECT_TRUE(rx(0x000, {0x01, 0x00}).empty());
  for (int i = 0; i < 2; ++i) {
    const auto out = sync_rx();
    EXPECT_EQ(out, one(0x181, {0x02, 0x00, 0xE1, 0x00, 0x00, 0x00, 0x00, 0x00}));
    EXPECT_EQ(out.at(0).dlc, 8);
    bus.run_for(ms(100));
  }
}

// Fig. 30: decimal digits. The second answer is printed as a copy of the
// first (sub 01, value 3); the text says 1 digit (spec §11 #16).
TEST_F(Trace, Fig30DecimalDigits) {
  boot();
  EXPECT_EQ(rx(0x601, {0x40, 0x32, 0x61, 0x01, 0, 0, 0, 0}), one(0x581, {0x42, 0x32, 0x61, 0x01, 0x03, 0, 0, 0}));
  EXPECT_EQ(rx(0x601, {0x40, 0x32, 0x61, 0x02, 0, 0, 0, 0}), one(0x581, {0x42, 0x32, 0x61, 0x02, 0x01, 0, 0, 0}));
}

// Fig. 32: REAL32 pressure + temperature. The 1800:01 row is garbled and
// rebuilt from Fig. 33; its confirmation echoes sub 01, not the printed 00
// (spec §11 #12).
TEST_F(Trace, Fig32FloatingPointPdo) {
  boot();
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x1A, 0x00, 0, 0, 0, 0}), confirmed(0x1A00, 0));
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x30, 0x61}), confirmed(0x1A00, 1));
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x1A, 0x02, 0x20, 0x02, 0x30, 0x61}), confirmed(0x1A00, 2));
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x1A, 0x00, 0x02, 0, 0, 0}), confirmed(0x1A00, 0));
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x18, 0x01, 0x81, 0x01, 0x00, 0x80}), confirmed(0x1800, 1));
  start();
  EXPECT_EQ(sync_rx(), one(0x181, {0x6F, 0x12, 0x03, 0x3B, 0x00, 0x00, 0xB4, 0x41}));
}

// Fig. 33: one visible string per PDO, "0.002   " and "22.5    ". The second
// SYNC of the pressure example has no printed answer: the device answers every
// SYNC (transmission type 1).
TEST_F(Trace, Fig33VisibleStringPdo) {
  boot();
  for (std::uint8_t sub : {1, 2}) {
    EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x1A, 0x00, 0, 0, 0, 0}), confirmed(0x1A00, 0));
    EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x1A, 0x01, 0x40, sub, 0x30, 0x51}), confirmed(0x1A00, 1));
    EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x1A, 0x00, 0x01, 0, 0, 0}), confirmed(0x1A00, 0));
    EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x18, 0x01, 0x81, 0x01, 0x00, 0x80}), confirmed(0x1800, 1));
    nmt(0x01);
    const auto out = sync_rx();
    if (sub == 1) EXPECT_EQ(out, one(0x181, {0x30, 0x2E, 0x30, 0x30, 0x32, 0x20, 0x20, 0x20}));
    else EXPECT_EQ(out, one(0x181, {0x32, 0x32, 0x2E, 0x35, 0x20, 0x20, 0x20, 0x20}));
    EXPECT_EQ(sync_rx().size(), 1u);
    nmt(0x80);
  }
}

// Fig. 34: hPa (SI), then psi via 0x2032 (non-SI), then the temperature unit.
TEST_F(Trace, Fig34ChangingUnits) {
  boot();
  source->bar = 1.5;
  EXPECT_EQ(rx(0x601, {0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0x22, 0x02}), confirmed(0x6131, 1));
  EXPECT_NEAR(real(0x6130, 1), 1500.0f, 0.01f);
  EXPECT_EQ(rx(0x601, {0x22, 0x32, 0x20, 0x00, 0x66, 0x34, 0x8D, 0x3D}), confirmed(0x2032, 0));
  EXPECT_EQ(rx(0x601, {0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0xA0, 0x00}), confirmed(0x6131, 1));
  EXPECT_NEAR(real(0x6130, 1), 21.7557f, 0.001f);
  // As printed the frame addresses 6132:02 (decimal digits): with s = 0 the
  // low byte 00 is stored, so the temperature has 0 decimals (spec §11 #17).
  EXPECT_EQ(rx(0x601, {0x22, 0x32, 0x61, 0x02, 0x00, 0x00, 0xA0, 0x00}), confirmed(0x6132, 2));
  EXPECT_EQ(u(0x6132, 2), 0u);
  // The intended write, 6131:02 = non-SI = degF.
  EXPECT_EQ(rx(0x601, {0x22, 0x31, 0x61, 0x02, 0x00, 0x00, 0xA0, 0x00}), confirmed(0x6131, 2));
  EXPECT_NEAR(real(0x6130, 2), 72.5f, 0.001f);
}

// Fig. 35a: type 5, a PDO on every 5th SYNC.
TEST_F(Trace, Fig35SynchronousEvery5th) {
  boot();
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x18, 0x02, 0x05, 0, 0, 0}), confirmed(0x1800, 2));
  start();
  for (int n = 1; n <= 10; ++n) EXPECT_EQ(sync_rx().size(), n % 5 == 0 ? 1u : 0u) << "SYNC " << n;
}

// Fig. 35b: type 0 with a 5000 ms event timer: a PDO on the first SYNC once
// 5 s have passed. The type-0 confirmation is printed with index 6131 sub 01
// (copy error, spec §11 #21): the real index / sub are echoed.
TEST_F(Trace, Fig35SynchronousWithEventTimer) {
  boot();
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x18, 0x05, 0x88, 0x13, 0, 0}), confirmed(0x1800, 5));
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x18, 0x02, 0x00, 0, 0, 0}), confirmed(0x1800, 2));
  start();
  std::vector<int> answered;
  for (int n = 0; n < 12; ++n) {
    if (!sync_rx().empty()) answered.push_back(n);
    bus.run_for(ms(1000) - ms(5));
  }
  EXPECT_EQ(answered, (std::vector<int>{0, 5, 10}));
}

// Fig. 35c: type 254 with 5000 ms: a PDO every 5 s, no SYNC needed.
TEST_F(Trace, Fig35AsynchronousEvery5s) {
  boot();
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x18, 0x05, 0x88, 0x13, 0, 0}), confirmed(0x1800, 5));
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x18, 0x02, 0xFE, 0, 0, 0}), confirmed(0x1800, 2));
  const TimeUs t0 = bus.now();
  nmt(0x01);
  bus.run_for(ms(15001));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 3u);
  for (std::size_t k = 0; k < out.size(); ++k) {
    EXPECT_EQ(out[k].frame.id, 0x181u);
    EXPECT_EQ(out[k].time, t0 + ms(5000) * TimeUs(k + 1));
  }
}

// Fig. 36: offsets of 10 bar / 10 degC. Both confirmations are printed with
// index 6131 (spec §11 #21): the real index 6124 is echoed.
TEST_F(Trace, Fig36Offsets) {
  boot();
  EXPECT_EQ(rx(0x601, {0x40, 0x31, 0x61, 0x01, 0, 0, 0, 0}),
            one(0x581, {0x42, 0x31, 0x61, 0x01, 0x00, 0x00, 0x4E, 0x00}));
  EXPECT_EQ(rx(0x601, {0x22, 0x24, 0x61, 0x01, 0x00, 0x00, 0x20, 0x41}), confirmed(0x6124, 1));
  EXPECT_NEAR(real(0x6130, 1), 10.002f, 1e-4f);
  EXPECT_EQ(rx(0x601, {0x40, 0x31, 0x61, 0x02, 0, 0, 0, 0}),
            one(0x581, {0x42, 0x31, 0x61, 0x02, 0x00, 0x00, 0x2D, 0x00}));
  EXPECT_EQ(rx(0x601, {0x22, 0x24, 0x61, 0x02, 0x00, 0x00, 0x20, 0x41}), confirmed(0x6124, 2));
  EXPECT_NEAR(real(0x6130, 2), 32.5f, 1e-4f);
}

// Fig. 37: calibration dates. The 2801 answers are printed with index 2800
// (spec §11 #21): the real index is echoed.
TEST_F(Trace, Fig37CalibrationDates) {
  boot();
  EXPECT_EQ(rx(0x601, {0x40, 0x00, 0x28, 0x01, 0, 0, 0, 0}),
            one(0x581, {0x42, 0x00, 0x28, 0x01, 0x32, 0x38, 0x30, 0x31}));
  EXPECT_EQ(rx(0x601, {0x40, 0x00, 0x28, 0x02, 0, 0, 0, 0}),
            one(0x581, {0x42, 0x00, 0x28, 0x02, 0x32, 0x30, 0x30, 0x32}));
  EXPECT_EQ(rx(0x601, {0x40, 0x01, 0x28, 0x01, 0, 0, 0, 0}),
            one(0x581, {0x42, 0x01, 0x28, 0x01, 0x32, 0x38, 0x30, 0x31}));
  EXPECT_EQ(rx(0x601, {0x40, 0x01, 0x28, 0x02, 0, 0, 0, 0}),
            one(0x581, {0x42, 0x01, 0x28, 0x02, 0x32, 0x30, 0x30, 0x33}));
}

// Fig. 38: zero correction, 'save', PIN, calibration dates. The PIN bytes
// are printed only as "PIN" (value not given): the profile's placeholder PIN.
TEST_F(Trace, Fig38ZeroPointAndDates) {
  boot();
  source->bar = 0.35;
  EXPECT_EQ(rx(0x601, {0x22, 0x24, 0x61, 0x01, 0x00, 0x00, 0x00, 0x00}), confirmed(0x6124, 1));
  EXPECT_EQ(rx(0x601, {0x22, 0x25, 0x61, 0x01, 0x7A, 0x65, 0x72, 0x6F}), confirmed(0x6125, 1));
  EXPECT_NEAR(real(0x6130, 1), 0.0f, 1e-4f);
  EXPECT_EQ(rx(0x601, {0x22, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65}), confirmed(0x1010, 1));
  EXPECT_EQ(rx(0x601, {0x22, 0xFF, 0x20, 0x00, 0x34, 0x12, 0x00, 0x00}), confirmed(0x20FF, 0));
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x28, 0x01, 0x32, 0x38, 0x30, 0x31}), confirmed(0x2800, 1));
  EXPECT_EQ(rx(0x601, {0x22, 0x00, 0x28, 0x02, 0x32, 0x30, 0x30, 0x33}), confirmed(0x2800, 2));
  EXPECT_EQ(rx(0x601, {0x22, 0x01, 0x28, 0x01, 0x32, 0x38, 0x30, 0x31}), confirmed(0x2801, 1));
  EXPECT_EQ(rx(0x601, {0x22, 0x01, 0x28, 0x02, 0x32, 0x30, 0x30, 0x34}), confirmed(0x2801, 2));
  EXPECT_EQ(rx(0x601, {0x40, 0x01, 0x28, 0x02, 0, 0, 0, 0}),
            one(0x581, {0x42, 0x01, 0x28, 0x02, 0x32, 0x30, 0x30, 0x34}));
}

}  // namespace
}  // namespace cansim::test
