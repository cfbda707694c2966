// Gems 9000: the spec's top 15 acceptance checks (gems-9000.md §12), one test
// each; node 1, default profile, scenario P = 0.002 bar, T = 22.5 degC.
#include <gtest/gtest.h>

#include <cmath>

#include "gems9000_support.hpp"

namespace cansim::test {
namespace {

using Accept = GemsFixture;

// 1
TEST_F(Accept, BootUpPreOperationalNoHeartbeatNoPdo) {
  bus.power_on_all();
  bus.run_for(ms(3000));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x701, {0x00}));
  EXPECT_EQ(out[0].frame.dlc, 1);
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  sync();
  EXPECT_TRUE(frames_for(ms(10)).empty());
}

// 2
TEST_F(Accept, DeviceTypeRead) {
  boot();
  EXPECT_EQ(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), one(0x581, {0x42, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
}

// 3
TEST_F(Accept, SdoErrors) {
  boot();
  EXPECT_EQ(sdo({0x40, 0x00, 0x10, 0x01, 0, 0, 0, 0}), aborted(0x1000, 1, 0x06090011));
  EXPECT_EQ(sdo({0x40, 0x05, 0x10, 0x00, 0, 0, 0, 0}), aborted(0x1005, 0, 0x06020000));
  EXPECT_EQ(sdo({0x23, 0x00, 0x10, 0x00, 0, 0, 0, 0}), aborted(0x1000, 0, 0x06010002));
  EXPECT_EQ(sdo({0x21, 0x00, 0x10, 0x00, 0, 0, 0, 0}), aborted(0x1000, 0, 0x05040001));
  EXPECT_EQ(sdo({0x2B, 0x32, 0x61, 0x01, 0x03, 0, 0, 0}), aborted(0x6132, 1, 0x06070010));
  EXPECT_EQ(sdo({0x40, 0x25, 0x61, 0x01, 0, 0, 0, 0}), aborted(0x6125, 1, 0x06010001));
  EXPECT_EQ(sdo({0x40, 0x00, 0x18, 0x03, 0, 0, 0, 0}), aborted(0x1800, 3, 0x06090011));
  // Only expedited: an 8-byte string is refused with a general error.
  EXPECT_EQ(sdo({0x40, 0x30, 0x51, 0x01, 0, 0, 0, 0}), aborted(0x5130, 1, 0x08000000));
}

// 4
TEST_F(Accept, Heartbeat) {
  boot();
  EXPECT_EQ(sdo({0x22, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0}), confirmed(0x1017, 0));
  const TimeUs t0 = bus.now() - ms(1);
  bus.run_until(t0 + ms(3500));
  auto out = bus.take();
  ASSERT_EQ(out.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(out[k].frame, F(0x701, {0x7F}));
    EXPECT_NEAR(double(out[k].time - t0), double(ms(1000) * TimeUs(k + 1)), double(ms(100)));
  }
  nmt(0x01, 0x00);
  EXPECT_EQ(frames_for(ms(1000)), one(0x701, {0x05}));
  nmt(0x02);
  EXPECT_EQ(frames_for(ms(1000)), one(0x701, {0x04}));
  nmt(0x80);
  ASSERT_TRUE(write32(0x1017, 0, 0));
  EXPECT_TRUE(frames_for(ms(5000)).empty());
}

// 5
TEST_F(Accept, DefaultPdoOnEverySync) {
  boot();
  start();
  for (int i = 0; i < 3; ++i) {
    sync();
    const auto out = frames_for(ms(1));
    EXPECT_EQ(out, one(0x181, {0x02, 0x00, 0xE1, 0x00, 0, 0, 0, 0}));
    EXPECT_EQ(out.at(0).dlc, 8);
  }
  EXPECT_EQ(sdo({0x40, 0x30, 0x61, 0x01, 0, 0, 0, 0}), one(0x581, {0x42, 0x30, 0x61, 0x01, 0x6F, 0x12, 0x03, 0x3B}));
  EXPECT_EQ(sdo({0x40, 0x32, 0x61, 0x01, 0, 0, 0, 0}), one(0x581, {0x42, 0x32, 0x61, 0x01, 0x03, 0, 0, 0}));
  EXPECT_EQ(sdo({0x40, 0x32, 0x61, 0x02, 0, 0, 0, 0}), one(0x581, {0x42, 0x32, 0x61, 0x02, 0x01, 0, 0, 0}));
}

// 6
TEST_F(Accept, NmtStates) {
  boot();
  nmt(0x02);
  bus.run_for(ms(1));
  EXPECT_TRUE(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}).empty());
  sync();
  EXPECT_TRUE(frames_for(ms(10)).empty());
  nmt(0x80);
  EXPECT_EQ(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}).size(), 1u);
  sync();
  EXPECT_TRUE(frames_for(ms(10)).empty());
  nmt(0x01, 0x02);  // another node
  bus.run_for(ms(1));
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
  nmt(0x01, 0x00);
  bus.run_for(ms(1));
  EXPECT_EQ(node().state(), NmtState::kOperational);
}

// 7
TEST_F(Accept, ResetSemantics) {
  boot();
  ASSERT_TRUE(write32(0x1017, 0, 1000));
  ASSERT_TRUE(write_real(0x6124, 1, 10.0f));
  nmt(0x82);
  EXPECT_EQ(frames_for(ms(1)), one(0x701, {0x00}));
  EXPECT_EQ(u(0x1017, 0), 0u);
  EXPECT_FLOAT_EQ(real(0x6124, 1), 10.0f);
  nmt(0x81);
  EXPECT_EQ(frames_for(ms(1)), one(0x701, {0x00}));
  EXPECT_FLOAT_EQ(real(0x6124, 1), 0.0f);
  // With 'save' before the resets both values survive.
  ASSERT_TRUE(write32(0x1017, 0, 1000));
  ASSERT_TRUE(write_real(0x6124, 1, 10.0f));
  ASSERT_TRUE(write32(0x1010, 1, 0x65766173));
  nmt(0x82);
  bus.run_for(ms(1));
  nmt(0x81);
  EXPECT_EQ(frames_for(ms(1)).at(0), F(0x701, {0x00}));
  EXPECT_EQ(u(0x1017, 0), 1000u);
  EXPECT_FLOAT_EQ(real(0x6124, 1), 10.0f);
}

// 8
TEST_F(Accept, FloatingPointMapping) {
  boot();
  for (auto [sub, v] : {std::pair{0, 0u}, {1, 0x61300120u}, {2, 0x61300220u}, {0, 2u}}) {
    EXPECT_EQ(sdo({0x22, 0x00, 0x1A, std::uint8_t(sub), std::uint8_t(v), std::uint8_t(v >> 8), std::uint8_t(v >> 16),
                   std::uint8_t(v >> 24)}),
              confirmed(0x1A00, std::uint8_t(sub)));
  }
  EXPECT_EQ(sdo({0x22, 0x00, 0x18, 0x01, 0x81, 0x01, 0x00, 0x80}), confirmed(0x1800, 1));
  EXPECT_EQ(u(0x1800, 1), 0x80000181u);  // read back as written
  start();
  sync();
  EXPECT_EQ(frames_for(ms(1)), one(0x181, {0x6F, 0x12, 0x03, 0x3B, 0x00, 0x00, 0xB4, 0x41}));
}

// 9
TEST_F(Accept, StringMappingAndMappingErrors) {
  boot();
  ASSERT_TRUE(write32(0x1A00, 0, 0));
  ASSERT_TRUE(write32(0x1A00, 1, 0x51300140));
  ASSERT_TRUE(write32(0x1A00, 0, 1));
  start();
  sync();
  EXPECT_EQ(frames_for(ms(1)), one(0x181, {0x30, 0x2E, 0x30, 0x30, 0x32, 0x20, 0x20, 0x20}));
  ASSERT_TRUE(write32(0x1A00, 0, 0));
  ASSERT_TRUE(write32(0x1A00, 1, 0x51300240));
  ASSERT_TRUE(write32(0x1A00, 0, 1));
  sync();
  EXPECT_EQ(frames_for(ms(1)), one(0x181, {0x32, 0x32, 0x2E, 0x35, 0x20, 0x20, 0x20, 0x20}));
  // Errors.
  ASSERT_TRUE(write32(0x1A00, 0, 0));
  EXPECT_EQ(sdo({0x22, 0x00, 0x1A, 0x02, 0x40, 0x01, 0x30, 0x51}), confirmed(0x1A00, 2));
  EXPECT_EQ(sdo({0x22, 0x00, 0x1A, 0x00, 0x02, 0, 0, 0}), aborted(0x1A00, 0, 0x06040042));
  EXPECT_EQ(sdo({0x22, 0x00, 0x1A, 0x03, 0x20, 0x00, 0x00, 0x10}), aborted(0x1A00, 3, 0x06040041));
  EXPECT_EQ(sdo({0x22, 0x00, 0x1A, 0x00, 0x05, 0, 0, 0}), aborted(0x1A00, 0, 0x06090030));
  ASSERT_TRUE(write32(0x1A00, 1, 0x61300120));
  ASSERT_TRUE(write32(0x1A00, 2, 0x61300220));
  ASSERT_TRUE(write32(0x1A00, 0, 2));
  EXPECT_EQ(sdo({0x22, 0x00, 0x1A, 0x01, 0x20, 0x02, 0x30, 0x61}), aborted(0x1A00, 1, 0x08000020));
}

// 10
TEST_F(Accept, TransmissionTypes) {
  boot();
  ASSERT_TRUE(write32(0x1800, 2, 5));
  start();
  for (int n = 1; n <= 10; ++n) {
    sync();
    EXPECT_EQ(frames_for(ms(1)).size(), n % 5 == 0 ? 1u : 0u) << n;
  }
  // Type 0 + 5000 ms, SYNC every second.
  ASSERT_TRUE(write32(0x1800, 5, 5000));
  ASSERT_TRUE(write32(0x1800, 2, 0));
  int sent = 0;
  TimeUs last = -1;
  for (int n = 0; n < 16; ++n) {
    sync();
    bus.run_for(ms(1000));
    for (const Sent& s : bus.take()) {
      if (last >= 0) {
        EXPECT_GE(s.time - last, ms(5000));
      }
      last = s.time;
      ++sent;
    }
  }
  EXPECT_EQ(sent, 3);  // SYNCs 5, 10, 15: the type-5 PDO at the 10th SYNC above counts as the last one
  // Type 254 + 5000 ms: no SYNC needed, SYNCs trigger nothing.
  ASSERT_TRUE(write32(0x1800, 2, 254));
  const TimeUs t0 = bus.now() - ms(1);
  for (int n = 0; n < 20; ++n) {
    sync();
    bus.run_for(ms(1000));
  }
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 4u);
  for (std::size_t k = 0; k < out.size(); ++k)
    EXPECT_NEAR(double(out[k].time - t0), double(ms(5000) * TimeUs(k + 1)), double(ms(250)));
  EXPECT_EQ(sdo({0x22, 0x00, 0x18, 0x02, 0xFF, 0, 0, 0}), aborted(0x1800, 2, 0x06090030));
  EXPECT_EQ(sdo({0x22, 0x00, 0x18, 0x02, 0xFC, 0, 0, 0}), aborted(0x1800, 2, 0x06090030));
}

// 11
TEST_F(Accept, Units) {
  boot();
  source->bar = 1.5;
  ASSERT_TRUE(write32(0x6131, 1, 0x02220000));  // hPa
  EXPECT_NEAR(real(0x6130, 1), 1500.0f, 0.01f);
  EXPECT_EQ(u(0x6132, 1), 0u);                    // 3 digits in bar = 0 in hPa
  EXPECT_NEAR(real(0x6149, 1), 10000.0f, 0.01f);  // span end converted
  ASSERT_TRUE(write32(0x2032, 0, 0x3D8D3466));
  ASSERT_TRUE(write32(0x6131, 1, 0x00A00000));  // psi as user unit
  EXPECT_NEAR(real(0x6130, 1), 21.7557f, 0.001f);
  EXPECT_EQ(u(0x6132, 1), 2u);
  EXPECT_EQ(i16(0x7130, 1), 2176);
  EXPECT_NEAR(real(0x6149, 1), 145.038f, 0.01f);
  ASSERT_TRUE(write32(0x6131, 2, 0x00A00000));  // degF
  EXPECT_NEAR(real(0x6130, 2), 72.5f, 0.001f);
  EXPECT_NEAR(real(0x6148, 2), -40.0f, 0.001f);
  EXPECT_NEAR(real(0x6149, 2), 185.0f, 0.001f);
  EXPECT_EQ(sdo({0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0x57, 0x00}), aborted(0x6131, 1, 0x06090030));
  // Offset follows as a difference.
  ASSERT_TRUE(write32(0x6131, 2, 0x002D0000));
  ASSERT_TRUE(write_real(0x6124, 2, 10.0f));
  ASSERT_TRUE(write32(0x6131, 2, 0x00A00000));
  EXPECT_NEAR(real(0x6124, 2), 18.0f, 0.001f);
}

// 12
TEST_F(Accept, OffsetFig36) {
  boot();
  EXPECT_EQ(sdo({0x40, 0x31, 0x61, 0x01, 0, 0, 0, 0}), one(0x581, {0x42, 0x31, 0x61, 0x01, 0x00, 0x00, 0x4E, 0x00}));
  start();
  sync();
  const std::int16_t before = std::int16_t(frames_for(ms(1)).at(0).data[0]);
  EXPECT_EQ(sdo({0x22, 0x24, 0x61, 0x01, 0x00, 0x00, 0x20, 0x41}), confirmed(0x6124, 1));
  EXPECT_NEAR(real(0x6130, 1), 10.002f, 1e-4f);
  sync();
  const CanFrame pdo = frames_for(ms(1)).at(0);
  const auto after = std::int16_t(pdo.data[0] | pdo.data[1] << 8);
  EXPECT_EQ(after - before, 10000);
}

// 13
TEST_F(Accept, ZeroCalibration) {
  boot();
  source->bar = 0.35;
  ASSERT_TRUE(write_real(0x6124, 1, 0.0f));
  EXPECT_EQ(sdo({0x22, 0x25, 0x61, 0x01, 0x7A, 0x65, 0x72, 0x6F}), confirmed(0x6125, 1));
  EXPECT_NEAR(real(0x6130, 1), 0.0f, 0.001f);
  EXPECT_FLOAT_EQ(real(0x6124, 1), 0.0f);  // hidden correction, not the offset
  EXPECT_EQ(sdo({0x22, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65}), confirmed(0x1010, 1));
  nmt(0x81);
  bus.run_for(ms(1));
  EXPECT_NEAR(real(0x6130, 1), 0.0f, 0.001f);
  power_cycle();
  bus.run_for(ms(1));
  bus.take();
  EXPECT_NEAR(real(0x6130, 1), 0.0f, 0.001f);
  EXPECT_EQ(sdo({0x22, 0x25, 0x61, 0x01, 0, 0, 0, 0}), aborted(0x6125, 1, 0x08000020));
  EXPECT_EQ(sdo({0x22, 0x10, 0x10, 0x01, 'x', 'x', 'x', 'x'}), aborted(0x1010, 1, 0x08000020));
}

// 14
TEST_F(Accept, PinAreaAndCalibrationDates) {
  boot();
  EXPECT_EQ(sdo({0x40, 0x00, 0x28, 0x01, 0, 0, 0, 0}), one(0x581, {0x42, 0x00, 0x28, 0x01, 0x32, 0x38, 0x30, 0x31}));
  EXPECT_EQ(sdo({0x40, 0x01, 0x28, 0x02, 0, 0, 0, 0}), one(0x581, {0x42, 0x01, 0x28, 0x02, 0x32, 0x30, 0x30, 0x33}));
  EXPECT_EQ(sdo({0x22, 0x00, 0x28, 0x02, '2', '0', '0', '3'}), aborted(0x2800, 2, 0x08000020));
  EXPECT_EQ(sdo({0x22, 0xFF, 0x20, 0x00, 0x35, 0x12, 0, 0}), aborted(0x20FF, 0, 0x08000020));  // wrong PIN
  EXPECT_EQ(sdo({0x40, 0x00, 0x28, 0x02, 0, 0, 0, 0}), one(0x581, {0x42, 0x00, 0x28, 0x02, '2', '0', '0', '2'}));
  ASSERT_TRUE(write32(0x20FF, 0, kPin));
  EXPECT_EQ(sdo({0x22, 0x00, 0x28, 0x02, '2', '0', '0', '3'}), confirmed(0x2800, 2));
  power_cycle();
  bus.run_for(ms(1));
  bus.take();
  EXPECT_EQ(sdo({0x40, 0x00, 0x28, 0x02, 0, 0, 0, 0}), one(0x581, {0x42, 0x00, 0x28, 0x02, '2', '0', '0', '3'}));
  EXPECT_EQ(sdo({0x40, 0xFF, 0x20, 0x00, 0, 0, 0, 0}), aborted(0x20FF, 0, 0x06010001));
  // Network initialisation 0: no boot-up, straight to operational at power-on.
  EXPECT_EQ(sdo({0x22, 0x13, 0x28, 0x00, 0, 0, 0, 0}), aborted(0x2813, 0, 0x08000020));  // locked again
  ASSERT_TRUE(write32(0x20FF, 0, kPin));
  ASSERT_TRUE(write32(0x2813, 0, 0));
  power_cycle();
  bus.run_for(ms(1));
  EXPECT_TRUE(bus.take().empty());
  EXPECT_EQ(node().state(), NmtState::kOperational);
  sync();
  EXPECT_EQ(frames_for(ms(1)), one(0x181, {0x02, 0x00, 0xE1, 0x00, 0, 0, 0, 0}));
}

// 15
TEST_F(Accept, LssAndEmcy) {
  boot();
  // LSS is ignored outside STOPPED (Table 4).
  master(0x7E5, {0x04, 0x01, 0, 0, 0, 0, 0, 0});
  EXPECT_TRUE(frames_for(ms(1)).empty());
  EXPECT_FALSE(node().lss().configuring());
  nmt(0x02);
  master(0x7E5, {0x04, 0x01, 0, 0, 0, 0, 0, 0});
  EXPECT_TRUE(frames_for(ms(1)).empty());
  master(0x7E5, {0x13, 0x00, 0x04, 0, 0, 0, 0, 0});
  EXPECT_EQ(frames_for(ms(1)), one(0x7E4, {0x13, 0x00, 0, 0, 0, 0, 0, 0}));
  master(0x7E5, {0x13, 0x04, 0x00, 0, 0, 0, 0, 0});
  EXPECT_EQ(frames_for(ms(1)), one(0x7E4, {0x13, 0x00, 0, 0, 0, 0, 0, 0}));
  master(0x7E5, {0x13, 0x00, 0x01, 0, 0, 0, 0, 0});
  EXPECT_EQ(frames_for(ms(1)), one(0x7E4, {0x13, 0x01, 0, 0, 0, 0, 0, 0}));
  master(0x7E5, {0x13, 0x00, 0x03, 0, 0, 0, 0, 0});  // back to 250 k before storing
  EXPECT_EQ(frames_for(ms(1)), one(0x7E4, {0x13, 0x00, 0, 0, 0, 0, 0, 0}));
  master(0x7E5, {0x11, 0x0A, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(frames_for(ms(1)), one(0x7E4, {0x11, 0x00, 0, 0, 0, 0, 0, 0}));
  master(0x7E5, {0x11, 0x80, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(frames_for(ms(1)), one(0x7E4, {0x11, 0x01, 0, 0, 0, 0, 0, 0}));
  master(0x7E5, {0x17, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(frames_for(ms(1)), one(0x7E4, {0x17, 0x00, 0, 0, 0, 0, 0, 0}));
  master(0x7E5, {0x04, 0x00, 0, 0, 0, 0, 0, 0});
  nmt(0x82, 0x00);
  EXPECT_EQ(frames_for(ms(1)), one(0x70A, {0x00}));
  EXPECT_EQ(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}, 0x0A),
            one(0x58A, {0x42, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
  // EMCY: sensor failure in operational, then cleared.
  nmt(0x01, 0x0A);
  bus.run_for(ms(20));
  bus.take();
  source->status = physics::kStatusInvalid;
  EXPECT_EQ(frames_for(ms(20)), one(0x8A, {0x01, 0x22, 0xC0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(u(0x1001, 0), 0xC0u);
  EXPECT_EQ(u(0x1003, 0), 1u);
  EXPECT_EQ(u(0x1003, 1), 0x2201u);
  source->status = 0;
  EXPECT_EQ(frames_for(ms(20)), one(0x8A, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0}));
  EXPECT_EQ(sdo({0x22, 0x03, 0x10, 0x00, 0x01, 0, 0, 0}, 0x0A),
            one(0x58A, {0x80, 0x03, 0x10, 0x00, 0x30, 0x00, 0x09, 0x06}));
  EXPECT_EQ(sdo({0x22, 0x03, 0x10, 0x00, 0x00, 0, 0, 0}, 0x0A), one(0x58A, {0x60, 0x03, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(u(0x1003, 0), 0u);
}

}  // namespace
}  // namespace cansim::test
