// Fault scheduling and the measurement faults applied in the sensor chain.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "physics/fault.hpp"
#include "physics/sensor.hpp"

using namespace cansim::physics;

namespace {

constexpr TimeUs kMs = 1000;
constexpr TimeUs kS = 1000000;

FaultSpec fault(FaultKind k, TimeUs at, TimeUs duration, TimeUs period = 0, std::uint32_t count = 0) {
  FaultSpec f;
  f.kind = k;
  f.timing.at_us = at;
  f.timing.duration_us = duration;
  f.timing.period_us = period;
  f.timing.count = count;
  return f;
}

std::vector<FaultEdge> drain(FaultSet& fs, TimeUs now) {
  std::vector<FaultEdge> v;
  FaultEdge e;
  while (fs.poll(now, e)) v.push_back(e);
  return v;
}

SensorSpec ideal() {
  SensorSpec s;
  for (ChannelSpec* c : {&s.pressure, &s.temperature}) {
    c->sample_rate_hz = 1000;
    c->adc.code_at_range_min = 0;
  }
  s.pressure.range_min = 0;
  s.pressure.range_max = 1e6;
  s.pressure.adc.code_at_range_max = 1e6;
  s.temperature.range_min = 200;
  s.temperature.range_max = 400;
  s.temperature.adc.code_at_range_max = 200000;
  return s;
}

ProcessModel proc(std::vector<TermSpec> p, double temp_k = 300.0) {
  ProcessSpec s;
  s.pressure = std::move(p);
  s.temperature = {ConstantSpec{temp_k}};
  return ProcessModel(s, 1);
}

}  // namespace

TEST(PhysicsFaultSchedule, AtAfterDurationRepeatCount) {
  FaultSet fs;
  // at 1 s for 0.5 s, every 2 s, 3 times -> [1,1.5) [3,3.5) [5,5.5)
  auto h = fs.add(fault(FaultKind::Silent, 1 * kS, kS / 2, 2 * kS, 3), 0);
  EXPECT_FALSE(fs.active(FaultKind::Silent, 999999));
  EXPECT_TRUE(fs.active(FaultKind::Silent, 1 * kS));
  EXPECT_TRUE(fs.active(FaultKind::Silent, 1 * kS + kS / 2 - 1));
  EXPECT_FALSE(fs.active(FaultKind::Silent, 1 * kS + kS / 2));
  TimeUs onset = 0;
  EXPECT_TRUE(fs.active(h, 3 * kS + 10, &onset));
  EXPECT_EQ(onset, 3 * kS);
  EXPECT_TRUE(fs.active(FaultKind::Silent, 5 * kS + 1));
  EXPECT_FALSE(fs.active(FaultKind::Silent, 7 * kS + 1));  // count exhausted
  EXPECT_FALSE(fs.active(FaultKind::BusOff, 1 * kS));

  // "after" is relative to the arm time (e.g. a control API request at 10 s).
  FaultSpec after;
  after.kind = FaultKind::HeartbeatStop;
  after.timing.after_us = 2 * kS;
  after.timing.duration_us = -1;  // until cancelled
  auto ha = fs.add(after, 10 * kS);
  EXPECT_FALSE(fs.active(FaultKind::HeartbeatStop, 11 * kS));
  EXPECT_TRUE(fs.active(FaultKind::HeartbeatStop, 12 * kS));
  EXPECT_TRUE(fs.active(FaultKind::HeartbeatStop, 1000 * kS));
  EXPECT_TRUE(fs.cancel(ha, 20 * kS));
  EXPECT_TRUE(fs.active(FaultKind::HeartbeatStop, 20 * kS - 1));
  EXPECT_FALSE(fs.active(FaultKind::HeartbeatStop, 20 * kS));
  EXPECT_FALSE(fs.cancel(1234, 0));

  // Unlimited repeats.
  FaultSet u;
  u.add(fault(FaultKind::SlowSdo, 0, 100, 1000), 0);
  EXPECT_TRUE(u.active(FaultKind::SlowSdo, 1000000 * kS + 50));
  EXPECT_FALSE(u.active(FaultKind::SlowSdo, 1000000 * kS + 150));
}

TEST(PhysicsFaultSchedule, EdgesArePolledInTimeOrder) {
  FaultSet fs;
  fs.add(fault(FaultKind::BusOff, 2 * kS, kS, 5 * kS, 2), 0);  // [2,3) [7,8)
  fs.add(fault(FaultKind::PowerCycle, 4 * kS, 0), 0);          // instantaneous at 4
  FaultSpec slow = fault(FaultKind::SlowSdo, 0, -1);
  slow.timing.at_us.reset();
  slow.timing.after_us = 500 * kMs;
  slow.sdo_delay_us = 300 * kMs;
  slow.id = 77;
  auto hs = fs.add(slow, 1 * kS);  // [1.5, cancelled at 7.5)
  EXPECT_EQ(fs.next_edge_time(), 1500 * kMs);
  EXPECT_TRUE(drain(fs, 1 * kS).empty());
  auto e1 = drain(fs, 4 * kS);
  ASSERT_EQ(e1.size(), 5u);
  EXPECT_EQ(e1[0].kind, FaultKind::SlowSdo);
  EXPECT_TRUE(e1[0].started);
  EXPECT_EQ(e1[0].time_us, 1500 * kMs);
  EXPECT_EQ(e1[0].spec->id, 77u);
  EXPECT_EQ(e1[0].spec->sdo_delay_us, 300 * kMs);
  EXPECT_EQ(e1[1].kind, FaultKind::BusOff);
  EXPECT_TRUE(e1[1].started);
  EXPECT_EQ(e1[2].kind, FaultKind::BusOff);
  EXPECT_FALSE(e1[2].started);
  EXPECT_EQ(e1[2].time_us, 3 * kS);
  EXPECT_EQ(e1[3].kind, FaultKind::PowerCycle);
  EXPECT_TRUE(e1[3].started);
  EXPECT_EQ(e1[4].kind, FaultKind::PowerCycle);
  EXPECT_FALSE(e1[4].started);
  EXPECT_FALSE(fs.active(FaultKind::PowerCycle, 4 * kS));  // instantaneous: never "active"
  fs.cancel(hs, 7500 * kMs);
  auto e2 = drain(fs, 100 * kS);
  ASSERT_EQ(e2.size(), 3u);
  EXPECT_EQ(e2[0].kind, FaultKind::BusOff);
  EXPECT_EQ(e2[0].occurrence, 1u);
  EXPECT_EQ(e2[0].time_us, 7 * kS);
  EXPECT_EQ(e2[1].kind, FaultKind::SlowSdo);
  EXPECT_FALSE(e2[1].started);
  EXPECT_EQ(e2[1].time_us, 7500 * kMs);
  EXPECT_EQ(e2[2].time_us, 8 * kS);
  EXPECT_EQ(fs.next_edge_time(), std::numeric_limits<TimeUs>::max());
  // Communication faults are only scheduled: query API for the node layer.
  FaultSet boot;
  boot.add(fault(FaultKind::EepromError, 0, -1), 0);
  EXPECT_TRUE(boot.active(FaultKind::EepromError, 0));
  EXPECT_FALSE(boot.has_measurement_faults());
  TimeUs onset = -1;
  EXPECT_NE(boot.active_spec(FaultKind::EepromError, 5, &onset), nullptr);
  EXPECT_EQ(onset, 0);
}

TEST(PhysicsFaultSchedule, NamesRoundTrip) {
  for (std::size_t i = 0; i < kFaultKindCount; ++i) {
    const auto k = static_cast<FaultKind>(i);
    EXPECT_EQ(parse_fault_kind(to_string(k)), k);
  }
  EXPECT_EQ(parse_fault_kind("bus_off"), FaultKind::BusOff);
  EXPECT_FALSE(parse_fault_kind("meteor"));
  EXPECT_TRUE(is_measurement_fault(FaultKind::OverTemperature));
  EXPECT_FALSE(is_measurement_fault(FaultKind::EepromError));
}

TEST(PhysicsFaultSensor, OpenAndShortInvalidateAndRail) {
  FaultSet fs;
  fs.add(fault(FaultKind::SensorOpen, 100 * kMs, 50 * kMs), 0);
  fs.add(fault(FaultKind::SensorShort, 300 * kMs, 50 * kMs), 0);
  auto spec = ideal();
  spec.pressure.adc.code_min = -100;
  spec.pressure.adc.code_max = 1100000;
  Sensor s(spec, proc({RampSpec{1e5, 2e5, 0, 1.0}}), 1, &fs);
  const double before = s.read(99 * kMs).pressure.value;
  const auto& o = s.read(120 * kMs).pressure;
  EXPECT_EQ(o.status, kStatusInvalid);
  EXPECT_EQ(o.adc_counts, -100);
  EXPECT_TRUE(o.flags & kFlagOpen);
  EXPECT_EQ(o.value, before);                       // hold last valid
  EXPECT_TRUE(s.read(150 * kMs).pressure.valid());  // ends at 150 ms
  const auto& sh = s.read(320 * kMs).pressure;
  EXPECT_FALSE(sh.valid());
  EXPECT_EQ(sh.adc_counts, 1100000);
  EXPECT_TRUE(s.read(350 * kMs).pressure.valid());
  EXPECT_TRUE(s.read(350 * kMs).temperature.valid());  // pressure channel only
  // PassThrough shows the rail value.
  spec.pressure.invalid_output = InvalidOutput::PassThrough;
  Sensor p(spec, proc({ConstantSpec{1e5}}), 1, &fs);
  EXPECT_EQ(p.read(310 * kMs).pressure.value, 1100000.0);
}

TEST(PhysicsFaultSensor, StuckFreezesAtOnsetOrGivenValue) {
  FaultSet fs;
  fs.add(fault(FaultKind::StuckValue, 200 * kMs, 100 * kMs), 0);
  FaultSpec fixed = fault(FaultKind::StuckValue, 500 * kMs, 100 * kMs);
  fixed.stuck_value = 123.0;
  fs.add(fixed, 0);
  // 1000 Pa per ms ramp.
  Sensor s(ideal(), proc({RampSpec{0, 1e6, 0, 1.0}}), 1, &fs);
  for (int n = 0; n < 200; n += 5) s.read(n * kMs);
  EXPECT_EQ(s.read(199 * kMs).pressure.value, 199000.0);
  for (int n = 200; n < 300; n += 5) {
    const auto& r = s.read(n * kMs).pressure;
    EXPECT_EQ(r.value, 199000.0) << n;  // frozen at the value shown before the onset
    EXPECT_TRUE(r.flags & kFlagStuck);
    EXPECT_TRUE(r.valid());
  }
  EXPECT_EQ(s.read(300 * kMs).pressure.value, 300000.0);  // follows again
  EXPECT_EQ(s.read(550 * kMs).pressure.value, 123.0);
  EXPECT_EQ(s.read(600 * kMs).pressure.value, 600000.0);
}

TEST(PhysicsFaultSensor, DriftGrowsDuringEachOccurrenceAndRepeats) {
  FaultSet fs;
  FaultSpec d = fault(FaultKind::Drift, 1 * kS, kS / 2, 2 * kS, 2);  // [1,1.5) [3,3.5)
  d.drift_per_s = 1000.0;                                            // Pa/s
  fs.add(d, 0);
  Sensor s(ideal(), proc({ConstantSpec{5e5}}), 1, &fs);
  EXPECT_EQ(s.read(999 * kMs).pressure.value, 5e5);
  EXPECT_EQ(s.read(1000 * kMs).pressure.value, 5e5);        // onset: zero drift yet
  EXPECT_EQ(s.read(1250 * kMs).pressure.value, 5e5 + 250);  // 0.25 s * 1000 Pa/s
  EXPECT_EQ(s.read(1499 * kMs).pressure.value, 5e5 + 499);
  EXPECT_EQ(s.read(1500 * kMs).pressure.value, 5e5);        // ended
  EXPECT_EQ(s.read(3100 * kMs).pressure.value, 5e5 + 100);  // second occurrence restarts
  EXPECT_EQ(s.read(5100 * kMs).pressure.value, 5e5);        // count exhausted
}

TEST(PhysicsFaultSensor, SpikesOnlyInsideTheirWindow) {
  FaultSet fs;
  FaultSpec sp = fault(FaultKind::Spikes, 1 * kS, 2 * kS);
  sp.spike_rate_hz = 20;  // ~40 spikes in 2 s
  sp.spike_amplitude = 5e4;
  fs.add(sp, 0);
  Sensor s(ideal(), proc({ConstantSpec{5e5}}), 1, &fs);
  int spikes = 0, pos = 0;
  for (int n = 0; n < 4000; ++n) {
    const double dv = s.read(n * kMs).pressure.value - 5e5;
    if (n < 1000 || n >= 3000) {
      ASSERT_EQ(dv, 0) << n;
    } else if (dv != 0) {
      EXPECT_EQ(std::abs(dv), 5e4);
      ++spikes;
      pos += dv > 0;
    }
  }
  EXPECT_GE(spikes, 20);
  EXPECT_LE(spikes, 65);
  EXPECT_GT(pos, 0);
  EXPECT_LT(pos, spikes);
}

TEST(PhysicsFaultSensor, NoiseBurstRaisesRmsOnlyDuringTheBurst) {
  FaultSet fs;
  FaultSpec nb = fault(FaultKind::NoiseBurst, 10 * kS, 10 * kS);
  nb.noise_rms = 2000;
  fs.add(nb, 0);
  auto spec = ideal();
  spec.pressure.noise_rms = 100;
  Sensor s(spec, proc({ConstantSpec{5e5}}), 1, &fs);
  auto rms = [&](int from_ms, int to_ms) {
    double s2 = 0;
    for (int n = from_ms; n < to_ms; ++n) {
      const double d = s.read(n * kMs).pressure.value - 5e5;
      s2 += d * d;
    }
    return std::sqrt(s2 / (to_ms - from_ms));
  };
  EXPECT_NEAR(rms(0, 10000), 100, 5);
  EXPECT_NEAR(rms(10000, 20000), std::sqrt(100.0 * 100 + 2000.0 * 2000), 100);
  EXPECT_NEAR(rms(20000, 30000), 100, 5);
}

TEST(PhysicsFaultSensor, OverTemperatureHeatsTheSensor) {
  FaultSet fs;
  FaultSpec ot = fault(FaultKind::OverTemperature, 1 * kS, 1 * kS);
  ot.over_temperature_k = 40;
  fs.add(ot, 0);
  auto spec = ideal();
  spec.pressure.errors.thermal_zero_per_k = 10;  // 10 Pa/K zero shift
  spec.pressure.errors.reference_temperature_k = 300;
  spec.temperature.range_max = 330;  // 40 K extra drives the temperature channel into overload
  Sensor s(spec, proc({ConstantSpec{5e5}}, 300.0), 1, &fs);
  const auto& r0 = s.read(500 * kMs);
  EXPECT_NEAR(r0.temperature.value, 300, 1e-3);  // one code = 0.65 mK
  EXPECT_EQ(r0.pressure.value, 5e5);
  const auto& r1 = s.read(1500 * kMs);
  EXPECT_NEAR(r1.temperature.value, 340, 1e-3);
  EXPECT_EQ(r1.temperature.status, kStatusPositiveOverload);
  EXPECT_EQ(r1.pressure.value, 5e5 + 400);  // thermal zero error at +40 K
  EXPECT_TRUE(r1.pressure.flags & kFlagFault);
  const auto& r2 = s.read(2500 * kMs);
  EXPECT_NEAR(r2.temperature.value, 300, 1e-3);
  EXPECT_EQ(s.counters(Channel::Temperature).positive, 1u);
}

TEST(PhysicsFaultSensor, TemperatureChannelFaultLeavesPressureAlone) {
  FaultSet fs;
  FaultSpec o = fault(FaultKind::SensorOpen, 0, -1);
  o.channel = FaultChannel::Temperature;
  fs.add(o, 0);
  Sensor s(ideal(), proc({ConstantSpec{5e5}}), 1, &fs);
  const auto& r = s.read(10 * kMs);
  EXPECT_FALSE(r.temperature.valid());
  EXPECT_TRUE(r.pressure.valid());
}

TEST(PhysicsFaultSensor, FilterIsNotPollutedByRailSamples) {
  FaultSet fs;
  fs.add(fault(FaultKind::SensorOpen, 100 * kMs, 50 * kMs), 0);
  auto spec = ideal();
  spec.pressure.filter = {FilterType::MovingAverage, 30};
  Sensor s(spec, proc({ConstantSpec{5e5}}), 1, &fs);
  for (int n = 0; n < 200; ++n) {
    const auto& r = s.read(n * kMs).pressure;
    EXPECT_EQ(r.value, 5e5) << n;  // held while invalid, clean restart afterwards
    EXPECT_EQ(r.valid(), n < 100 || n >= 150) << n;
  }
}

// The channel words are parsed and printed in one place (physics/channel.hpp).
TEST(ChannelNames, ParseAndPrintEachOther) {
  for (Channel c : {Channel::Pressure, Channel::Temperature}) EXPECT_EQ(parse_channel(channel_name(c)), c);
  EXPECT_EQ(channel_name(Channel::Temperature), "temperature");
  EXPECT_FALSE(parse_channel("Pressure").has_value());
  EXPECT_FALSE(parse_channel("both").has_value());
  EXPECT_EQ(parse_fault_channel("pressure"), FaultChannel::Pressure);
  EXPECT_EQ(parse_fault_channel("temperature"), FaultChannel::Temperature);
  EXPECT_EQ(parse_fault_channel("both"), FaultChannel::Both);
  EXPECT_FALSE(parse_fault_channel("humidity").has_value());
  for (FaultChannel c : {FaultChannel::Pressure, FaultChannel::Temperature, FaultChannel::Both})
    EXPECT_EQ(parse_fault_channel(to_string(c)), c);
}
