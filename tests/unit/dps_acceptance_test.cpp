// Honeywell DPS: the spec's top acceptance checks (honeywell-dps.md §13), one
// test each, node 0x7F, default profile unless a test switches a quirk off.
// Where the manual and the spec disagree the manual wins (docs/devices/dps.md).
#include <gtest/gtest.h>

#include "dps_support.hpp"

namespace cansim::test {
namespace {

using Accept = DpsFixture;

std::vector<CanFrame> abort_frame(std::uint16_t index, std::uint8_t sub, std::uint32_t code) {
  return sdo_aborted(Accept::kId, index, sub, code);
}
std::vector<CanFrame> download_ok(std::uint16_t index, std::uint8_t sub) {
  return sdo_confirmed(Accept::kId, index, sub);
}

void start(Accept& t) {
  t.nmt(0x01);
  t.bus.run_for(ms(1));
  t.bus.take();
}

// 1
TEST_F(Accept, BootUpThenSilence) {
  bus.power_on_all();
  bus.run_for(ms(1000));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame, F(0x77F, {0x00}));
  bus.run_for(ms(2000));
  EXPECT_TRUE(bus.take().empty());
  EXPECT_EQ(node().state(), NmtState::kPreOperational);
}

// 2
TEST_F(Accept, DefaultPdoEvery100msInPsi) {
  boot();
  source->psi = 50.0;
  const TimeUs t = bus.now();
  nmt(0x01);
  bus.run_for(ms(1000));
  const auto out = bus.take();
  ASSERT_EQ(out.size(), 10u);
  for (std::size_t k = 0; k < out.size(); ++k) {
    EXPECT_EQ(out[k].frame, F(0x1FF, {0x50, 0xC3, 0x00, 0x00}));
    EXPECT_EQ(out[k].time, t + ms(100) * TimeUs(k + 1));
  }
  source->psi = 12.3456;
  bus.run_for(ms(100));
  EXPECT_EQ(le32(bus.take().at(0).frame), 12346);
}

// 3
TEST_F(Accept, StopSilencesPdoAndSdoStartResumes) {
  boot();
  start(*this);
  nmt(0x02);
  bus.run_for(ms(500));
  EXPECT_TRUE(bus.take().empty());
  EXPECT_TRUE(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}).empty());
  nmt(0x01);
  bus.run_for(ms(250));
  EXPECT_EQ(on(0x1FF).size(), 2u);
}

// 4: the manual's Table 19 answers reads with 0x60 (default); strict CiA 301 gives 0x43 / 0x4F.
TEST_F(Accept, IdentityReads) {
  boot();
  EXPECT_EQ(frames(sdo({0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x18, 0x10, 0x01, 0x62, 0x03, 0x00, 0x00}));
  EXPECT_EQ(frames(sdo({0x40, 0x18, 0x10, 0x02, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x18, 0x10, 0x02, 0x50, 0x31, 0x44, 0x00}));
  EXPECT_EQ(frames(sdo({0x40, 0x18, 0x10, 0x03, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x18, 0x10, 0x03, 0x00, 0x00, 0x01, 0x00}));
  EXPECT_EQ(frames(sdo({0x40, 0x32, 0x61, 0x01, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x32, 0x61, 0x01, 0x03, 0x00, 0x00, 0x00}));
  EXPECT_EQ(u(0x200E, 0), u(0x1018, 4));
}

TEST_F(Accept, IdentityReadsStrictCia301) {
  bus = SimBus();
  build([](config::Profile& p) { p.options->sdo_upload_response_0x60 = false; });
  boot();
  EXPECT_EQ(frames(sdo({0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0})),
            one(0x5FF, {0x43, 0x18, 0x10, 0x01, 0x62, 0x03, 0x00, 0x00}));
  EXPECT_EQ(frames(sdo({0x40, 0x18, 0x10, 0x02, 0, 0, 0, 0})),
            one(0x5FF, {0x43, 0x18, 0x10, 0x02, 0x50, 0x31, 0x44, 0x00}));
  EXPECT_EQ(frames(sdo({0x40, 0x18, 0x10, 0x03, 0, 0, 0, 0})),
            one(0x5FF, {0x43, 0x18, 0x10, 0x03, 0x00, 0x00, 0x01, 0x00}));
  EXPECT_EQ(frames(sdo({0x40, 0x32, 0x61, 0x01, 0, 0, 0, 0})),
            one(0x5FF, {0x4F, 0x32, 0x61, 0x01, 0x03, 0x00, 0x00, 0x00}));
  EXPECT_EQ(frames(sdo({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0})),
            one(0x5FF, {0x47, 0x08, 0x10, 0x00, 'D', 'P', 'S', 0x00}));
}

// 5
TEST_F(Accept, UnitChangeConvertsEverything) {
  boot();
  source->psi = 50.0;
  EXPECT_EQ(frames(sdo({0x23, 0x24, 0x61, 0x01, 0xF4, 0x01, 0, 0})), download_ok(0x6124, 1));  // +0.5 psi
  bus.take();
  EXPECT_EQ(frames(sdo({0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0x4E, 0x00})), download_ok(0x6131, 1));
  EXPECT_EQ(u(0x6131, 1), 0x004E0000u);
  // 50.5 psi = 3.48185 bar; offset 0.5 psi = 0.03447 bar; span 100 psi = 6.89476 bar
  EXPECT_EQ(i32(0x6130, 1), 3481);  // 3.447379 bar + the offset as stored, 0.034 bar
  EXPECT_EQ(i32(0x6124, 1), 34);
  EXPECT_EQ(i32(0x6148, 1), 0);
  EXPECT_EQ(i32(0x6149, 1), 6895);
  EXPECT_EQ(i32(0x2006, 0), 6895);
  start(*this);
  bus.run_for(ms(100));
  EXPECT_NEAR(le32(on(0x1FF).at(0).frame), 3481, 1);
  EXPECT_EQ(frames(sdo({0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0x22, 0x00})), abort_frame(0x6131, 1, 0x06090031));
  EXPECT_EQ(frames(sdo({0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0x22, 0x03})), download_ok(0x6131, 1));
  EXPECT_EQ(i32(0x6149, 1), 689500);  // 6.895 bar converted again, not 100 psi
}

// 6
TEST_F(Accept, UnitPersistsThroughSaveAndRestore) {
  boot();
  sdo({0x22, 0x31, 0x61, 0x01, 0x00, 0x00, 0x4E, 0x00});
  EXPECT_EQ(frames(sdo({0x22, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65})), download_ok(0x1010, 1));
  nmt(0x81);
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()), one(0x77F, {0x00}));
  EXPECT_EQ(u(0x6131, 1), 0x004E0000u);
  EXPECT_EQ(i32(0x6149, 1), 6895);
  EXPECT_EQ(frames(sdo({0x22, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64})), download_ok(0x1011, 1));
  nmt(0x81);
  bus.run_for(ms(1));
  EXPECT_EQ(u(0x6131, 1), 0x00AB0000u);
  EXPECT_EQ(i32(0x6149, 1), 100000);
  bus.take();
  // A wrong signature is a general error (manual Table 23 has no 0x08000020).
  EXPECT_EQ(frames(sdo({0x22, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x00})), abort_frame(0x1010, 1, 0x08000000));
}

// 7
TEST_F(Accept, PdoParametersAreNotStored) {
  boot();
  EXPECT_EQ(frames(sdo({0x2B, 0x00, 0x18, 0x05, 0xE8, 0x03, 0, 0})), download_ok(0x1800, 5));
  sdo({0x22, 0x17, 0x10, 0x00, 0x0A, 0x00, 0, 0});  // heartbeat 10 ms, stored
  sdo({0x22, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65});
  power_cycle();
  bus.run_for(ms(1));
  EXPECT_EQ(u(0x1800, 5), 100u);
  EXPECT_EQ(u(0x1017, 0), 10u);
  bus.take();
  start(*this);
  bus.run_for(ms(300));
  EXPECT_EQ(on(0x1FF).size(), 3u);
}

// 8
TEST_F(Accept, EventTimer) {
  boot();
  start(*this);
  const TimeUs t = bus.now();
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x18, 0x05, 0xE8, 0x03, 0x00, 0x00})), download_ok(0x1800, 5));
  bus.run_until(t + ms(2500));
  EXPECT_EQ(on(0x1FF).size(), 2u);
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x18, 0x05, 0x03, 0x00, 0x00, 0x00})), abort_frame(0x1800, 5, 0x06090031));
  EXPECT_EQ(frames(sdo({0x40, 0x00, 0x18, 0x03, 0, 0, 0, 0})),
            one(0x5FF, {0x80, 0x00, 0x18, 0x03, 0x11, 0x00, 0x09, 0x06}));
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x18, 0x05, 0x04, 0x00, 0x00, 0x00})), download_ok(0x1800, 5));
  // Types outside Table 17 (RTR-only 0xFC / 0xFD, reserved) are refused.
  for (std::uint8_t type : {0xF1, 0xFC, 0xFD}) {
    master(0x67F, {0x2F, 0x00, 0x18, 0x02, type, 0, 0, 0});
    bus.run_for(ms(1));
    EXPECT_EQ(frames(on(0x5FF)), abort_frame(0x1800, 2, 0x06090031));
  }
}

// 9
TEST_F(Accept, SyncCyclicEveryThirdSync) {
  boot();
  sdo({0x2F, 0x00, 0x18, 0x02, 0x03, 0, 0, 0});
  for (int k = 0; k < 6; ++k) {  // pre-operational: none
    sync();
    bus.run_for(ms(10));
  }
  EXPECT_TRUE(on(0x1FF).empty());
  start(*this);
  bus.run_for(ms(1000));
  EXPECT_TRUE(on(0x1FF).empty());  // none without SYNC
  for (int k = 1; k <= 9; ++k) {
    sync();
    bus.run_for(ms(10));
    EXPECT_EQ(on(0x1FF).size(), k % 3 == 0 ? 1u : 0u) << k;
  }
  bus.inject(CanFrame::make(0x080, {0x05}));  // a SYNC with counter byte counts too
  bus.inject(CanFrame::make(0x080, {0x06}));
  bus.inject(CanFrame::make(0x080, {0x07}));
  bus.run_for(ms(1));
  EXPECT_EQ(on(0x1FF).size(), 1u);
}

// 10
TEST_F(Accept, SyncAcyclicOnlyOnChange) {
  boot();
  start(*this);
  source->psi = 20.0;
  sdo({0x2F, 0x00, 0x18, 0x02, 0x00, 0, 0, 0});
  bus.run_for(ms(20));
  for (int k = 0; k < 5; ++k) {
    sync();
    bus.run_for(ms(10));
    EXPECT_EQ(on(0x1FF).size(), k == 0 ? 1u : 0u) << k;
  }
  source->psi = 20.001;  // one LSB
  bus.run_for(ms(5));
  sync();
  bus.run_for(ms(10));
  const auto out = on(0x1FF);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(le32(out[0].frame), 20001);
  sync();
  bus.run_for(ms(10));
  EXPECT_TRUE(on(0x1FF).empty());
}

// 11
TEST_F(Accept, RawMapping) {
  boot();
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x18, 0x01, 0xFF, 0x01, 0x00, 0xC0})), download_ok(0x1800, 1));
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x1A, 0x00, 0x00, 0, 0, 0})), download_ok(0x1A00, 0));
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x1A, 0x01, 0x20, 0x00, 0x00, 0x10})), abort_frame(0x1A00, 1, 0x06040041));
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x00, 0x71})), abort_frame(0x1A00, 1, 0x06040041));
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x1A, 0x01, 0x10, 0x01, 0x00, 0x71})), download_ok(0x1A00, 1));
  EXPECT_EQ(frames(sdo({0x2F, 0x00, 0x1A, 0x00, 0x01, 0, 0, 0})), download_ok(0x1A00, 0));
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x18, 0x01, 0xFF, 0x01, 0x00, 0x40})), download_ok(0x1800, 1));
  // While mapped, entries are locked (vendor general error).
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x30, 0x61})), abort_frame(0x1A00, 1, 0x08000000));
  start(*this);
  std::int64_t last = -1;
  for (double psi : {0.0, 25.0, 50.0, 100.0}) {
    source->psi = psi;
    bus.run_for(ms(100));
    const auto out = on(0x1FF);
    ASSERT_EQ(out.size(), 1u);
    ASSERT_EQ(out[0].frame.dlc, 2);
    const std::int64_t raw = std::int16_t(out[0].frame.data[0] | out[0].frame.data[1] << 8);
    EXPECT_NEAR(raw, (psi + 5.0) / 110.0 * 4095.0, 1.0);
    EXPECT_GT(raw, last);
    EXPECT_LE(raw, 4095);
    last = raw;
  }
}

// 12: autozero also shifts span start / end (manual §10.5, vendor autozero_shifts_span).
TEST_F(Accept, AutoZero) {
  boot();
  source->psi = 3.0;
  EXPECT_EQ(frames(sdo({0x22, 0x25, 0x61, 0x01, 0x7A, 0x65, 0x72, 0x6F})), download_ok(0x6125, 1));
  EXPECT_NEAR(double(i32(0x6130, 1)), 0.0, 1.0);
  EXPECT_EQ(i32(0x6148, 1), -3000);
  EXPECT_EQ(i32(0x6149, 1), 97000);
  start(*this);
  bus.run_for(ms(100));
  EXPECT_NEAR(le32(on(0x1FF).at(0).frame), 0, 1);
  source->psi = 4.0;
  bus.run_for(ms(100));
  EXPECT_NEAR(le32(on(0x1FF).at(0).frame), 1000, 1);
  EXPECT_EQ(frames(sdo({0x40, 0x25, 0x61, 0x01, 0, 0, 0, 0})), abort_frame(0x6125, 1, 0x06010001));
  EXPECT_EQ(frames(sdo({0x23, 0x25, 0x61, 0x01, 0x7A, 0x65, 0x72, 0x00})), abort_frame(0x6125, 1, 0x06090031));
  // Stored with 0x1010 like the other Table 18 values.
  sdo({0x22, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65});
  power_cycle();
  bus.run_for(ms(1));
  EXPECT_EQ(i32(0x6124, 1), -3000);
}

TEST_F(Accept, AutoZeroStrictCia404KeepsSpan) {
  bus = SimBus();
  build([](config::Profile& p) { std::get<model::DpsSettings>(p.device).autozero_shifts_span = false; });
  boot();
  source->psi = 3.0;
  sdo({0x22, 0x25, 0x61, 0x01, 0x7A, 0x65, 0x72, 0x6F});
  EXPECT_EQ(i32(0x6124, 1), -3000);
  EXPECT_EQ(i32(0x6148, 1), 0);
  EXPECT_EQ(i32(0x6149, 1), 100000);
}

// 13: the spec (after the manual's Table 8) says 0x7FF; 0x700 + node-ID is 0x77F (Table 15).
TEST_F(Accept, Heartbeat) {
  boot();
  const TimeUs t = bus.now();
  EXPECT_EQ(frames(sdo({0x22, 0x17, 0x10, 0x00, 0x64, 0x00, 0x00, 0x00})), download_ok(0x1017, 0));
  bus.run_until(t + ms(300));
  auto out = bus.take();
  ASSERT_EQ(out.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(out[k].frame, F(0x77F, {0x7F}));
    EXPECT_EQ(out[k].time, t + ms(100) * TimeUs(k + 1));
  }
  nmt(0x01);
  bus.run_until(t + ms(400));
  EXPECT_EQ(on(0x77F).at(0).frame, F(0x77F, {0x05}));
  nmt(0x02);
  bus.run_until(t + ms(600));
  out = on(0x77F);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1].frame, F(0x77F, {0x04}));
}

// 14
TEST_F(Accept, LssNodeId) {
  boot();
  master(0x7E5, {0x04, 0x01, 0, 0, 0, 0, 0, 0});
  master(0x7E5, {0x11, 0x7E, 0, 0, 0, 0, 0, 0});
  master(0x7E5, {0x13, 0x00, 0x01, 0, 0, 0, 0, 0});  // 800 kbit/s: not in Table 7
  master(0x7E5, {0x17, 0, 0, 0, 0, 0, 0, 0});
  master(0x7E5, {0x04, 0x00, 0, 0, 0, 0, 0, 0});
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()),
            (std::vector<CanFrame>{F(0x7E4, {0x11, 0, 0, 0, 0, 0, 0, 0}), F(0x7E4, {0x13, 0x01, 0, 0, 0, 0, 0, 0}),
                                   F(0x7E4, {0x17, 0, 0, 0, 0, 0, 0, 0})}));
  nmt(0x81);
  bus.run_for(ms(1));
  EXPECT_EQ(frames(bus.take()), one(0x77E, {0x00}));
  EXPECT_TRUE(sdo({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}, 0x7F).empty());
  EXPECT_EQ(frames(sdo({0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}, 0x7E)),
            one(0x5FE, {0x60, 0x18, 0x10, 0x01, 0x62, 0x03, 0x00, 0x00}));
  nmt(0x01, 0x7E);
  bus.run_for(ms(100));
  EXPECT_EQ(on(0x1FE).size(), 1u);
  // Selective switching with one wrong identity field: no 0x44.
  const auto serial = std::uint32_t(u(0x1018, 4));
  master(0x7E5, {0x40, 0x62, 0x03, 0x00, 0x00, 0, 0, 0});
  master(0x7E5, {0x41, 0x50, 0x31, 0x44, 0x00, 0, 0, 0});
  master(0x7E5, {0x42, 0x00, 0x00, 0x02, 0x00, 0, 0, 0});
  master(0x7E5, {0x43, std::uint8_t(serial), std::uint8_t(serial >> 8), std::uint8_t(serial >> 16),
                 std::uint8_t(serial >> 24), 0, 0, 0});
  bus.run_for(ms(1));
  EXPECT_TRUE(on(0x7E4).empty());
}

// 15
TEST_F(Accept, ActivateBitTimingSilence) {
  boot();
  sdo({0x22, 0x17, 0x10, 0x00, 0x0A, 0x00, 0x00, 0x00});  // 10 ms heartbeat
  master(0x7E5, {0x04, 0x01, 0, 0, 0, 0, 0, 0});
  master(0x7E5, {0x13, 0x00, 0x04, 0, 0, 0, 0, 0});
  bus.run_for(ms(1));
  bus.take();
  const TimeUs t = bus.now();
  master(0x7E5, {0x15, 0xE8, 0x03, 0, 0, 0, 0, 0});
  bus.run_until(t + ms(1950));
  EXPECT_TRUE(bus.take().empty());
  bus.run_until(t + ms(2050));
  const auto out = bus.take();
  ASSERT_FALSE(out.empty());
  EXPECT_EQ(out[0].frame, F(0x77F, {0x7F}));
  EXPECT_GE(out[0].time, t + ms(2000));
  EXPECT_LE(out[0].time, t + ms(2050));
}

// 16 (extra): span overflow EMCY, counter, error history.
TEST_F(Accept, OverflowEmcy) {
  boot();
  source->psi = 50.0;
  bus.run_for(ms(10));
  source->psi = 101.0;
  bus.run_for(ms(10));
  EXPECT_EQ(frames(bus.take()), one(0x0FF, {0x01, 0x32, 0x05, 0, 0, 0, 0, 0}));
  EXPECT_EQ(u(0x2004, 0), 1u);
  EXPECT_EQ(u(0x1001, 0), 0x05u);
  source->psi = 99.0;
  bus.run_for(ms(10));
  EXPECT_EQ(frames(bus.take()), one(0x0FF, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0}));
  EXPECT_EQ(u(0x1003, 0), 1u);
  EXPECT_EQ(u(0x1003, 1), 0x00003201u);
  source->psi = -1.0;
  bus.run_for(ms(10));
  EXPECT_EQ(frames(bus.take()), one(0x0FF, {0x01, 0x32, 0x05, 0, 0, 0, 0, 0}));
  EXPECT_EQ(u(0x2005, 0), 1u);
  EXPECT_EQ(u(0x2004, 0), 1u);
}

TEST_F(Accept, SensorFailureEmcy) {
  boot();
  source->status = physics::kStatusInvalid;
  bus.run_for(ms(10));
  EXPECT_EQ(frames(bus.take()), one(0x0FF, {0x01, 0x22, 0x03, 0, 0, 0, 0, 0}));
  source->status = 0;
  bus.run_for(ms(10));
  EXPECT_EQ(frames(bus.take()), one(0x0FF, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0}));
}

TEST_F(Accept, OnlyExpeditedSdoAndVendorAbortCodes) {
  boot();
  EXPECT_EQ(frames(sdo({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0})),
            one(0x5FF, {0x60, 0x08, 0x10, 0x00, 'D', 'P', 'S', 0x00}));
  EXPECT_EQ(frames(sdo({0x21, 0x17, 0x10, 0x00, 2, 0, 0, 0})), abort_frame(0x1017, 0, 0x05040001));
  EXPECT_EQ(frames(sdo({0x23, 0x17, 0x10, 0x00, 1, 0, 0, 0})), abort_frame(0x1017, 0, 0x08000000));
  EXPECT_EQ(frames(sdo({0x40, 0x00, 0x14, 0x01, 0, 0, 0, 0})), abort_frame(0x1400, 1, 0x06020000));
  EXPECT_EQ(frames(sdo({0x22, 0x00, 0x10, 0x00, 1, 0, 0, 0})), abort_frame(0x1000, 0, 0x06010002));
}

}  // namespace
}  // namespace cansim::test
