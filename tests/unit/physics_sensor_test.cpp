// The measurement chain: filters, ADC, quantisation, errors, overload, damage, laziness.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <vector>

#include "physics/random.hpp"
#include "physics/sensor.hpp"
#include "physics/units.hpp"
#include "support/counting_new.hpp"  // proves that read() does not allocate

using namespace cansim::physics;
using cansim::test::g_allocations;
using cansim::test::kCountingNew;

namespace {

constexpr TimeUs kMs = 1000;

/// An "ideal" channel: 0..1e6 Pa mapped to codes 0..1e6 (1 code per Pa), 1 kHz, no errors.
ChannelSpec ideal_channel() {
  ChannelSpec c;
  c.range_min = 0;
  c.range_max = 1e6;
  c.sample_rate_hz = 1000;
  c.adc.code_at_range_min = 0;
  c.adc.code_at_range_max = 1e6;
  return c;
}

SensorSpec ideal_sensor() {
  SensorSpec s;
  s.pressure = ideal_channel();
  s.temperature = ideal_channel();
  s.temperature.range_min = 200;
  s.temperature.range_max = 400;
  s.temperature.adc.code_at_range_min = 0;
  s.temperature.adc.code_at_range_max = 200000;  // 1 mK per code
  return s;
}

ProcessModel process(std::vector<TermSpec> p, std::vector<TermSpec> t = {ConstantSpec{298.15}}) {
  ProcessSpec s;
  s.pressure = std::move(p);
  s.temperature = std::move(t);
  return ProcessModel(s, 77);
}

}  // namespace

TEST(PhysicsSensor, IdealChainReproducesTheTruth) {
  Sensor s(ideal_sensor(), process({ConstantSpec{123456.0}}, {ConstantSpec{300.0}}), 1);
  const auto& r = s.read(5 * kMs);
  EXPECT_EQ(r.pressure.value, 123456.0);
  EXPECT_EQ(r.pressure.truth, 123456.0);
  EXPECT_EQ(r.pressure.adc_counts, 123456);
  EXPECT_EQ(r.pressure.sample_index, 5);
  EXPECT_EQ(r.pressure.sample_time_us, 5 * kMs);
  EXPECT_EQ(r.pressure.status, 0);
  EXPECT_NEAR(r.pressure.fraction, 0.123456, 1e-12);
  EXPECT_NEAR(r.temperature.value, 300.0, 1e-9);
  EXPECT_TRUE(r.pressure.valid());
}

TEST(PhysicsSensor, MovingAverageReachesStepAfterExactlyNSamples) {
  auto spec = ideal_sensor();
  spec.pressure.filter = {FilterType::MovingAverage, 30};
  // Step 0 -> 300000 Pa at t = 100 ms (sample 100).
  Sensor s(spec, process({RampSpec{0, 300000, 0.1, 0}}), 1);
  for (int n = 0; n < 200; ++n) {
    const double v = s.read(n * kMs).pressure.value;
    if (n < 100) {
      EXPECT_EQ(v, 0) << n;
    } else if (n < 129) {
      EXPECT_DOUBLE_EQ(v, 300000.0 * (n - 99) / 30.0) << n;
      EXPECT_LT(v, 300000.0) << n;
    } else {
      EXPECT_EQ(v, 300000.0) << n;  // the 30th sample at the new level: exactly there
    }
  }
}

TEST(PhysicsSensor, RepeatingAverageUpdatesOncePerBlock) {
  auto spec = ideal_sensor();
  spec.pressure.filter = {FilterType::RepeatingAverage, 10};
  // Ramp 1000 Pa per ms: sample n has value 1000 n.
  Sensor s(spec, process({RampSpec{0, 1e6, 0, 1.0}}), 1);
  double prev = s.read(0).pressure.value;
  EXPECT_EQ(prev, 0);  // before the first block completes: the first sample
  int changes = 0;
  for (int n = 1; n < 100; ++n) {
    const double v = s.read(n * kMs).pressure.value;
    if ((n + 1) % 10 == 0) {
      // mean of samples n-9 .. n = 1000 (n - 4.5)
      EXPECT_DOUBLE_EQ(v, 1000.0 * (n - 4.5)) << n;
      ++changes;
    } else {
      EXPECT_EQ(v, prev) << n;
    }
    prev = v;
  }
  EXPECT_EQ(changes, 10);
}

// Lazy evaluation at arbitrary times must equal a device that evaluates every sample.
TEST(PhysicsSensor, LazyReadsEqualBruteForceSampling) {
  for (FilterType ft :
       {FilterType::None, FilterType::MovingAverage, FilterType::RepeatingAverage, FilterType::FirstOrder}) {
    auto spec = ideal_sensor();
    spec.pressure.filter = {ft, 37, 0.004};
    spec.pressure.noise_rms = 800.0;
    spec.pressure.errors.nonlinearity = 3000.0;
    spec.pressure.errors.thermal_zero_per_k = 50.0;
    spec.temperature.filter = {FilterType::MovingAverage, 100};
    spec.temperature.noise_rms = 0.05;
    auto make = [&] {
      return Sensor(spec,
                    process({ConstantSpec{4e5}, SineSpec{1e5, 3.0, 0.0}, PulseSpec{0, 5e4, 0.25, 0.5, 0.01, 0.0, 0.0}},
                            {ConstantSpec{300}, SineSpec{5, 0.5, 0}}),
                    99);
    };
    Sensor brute = make(), lazy = make();
    std::vector<SensorReading> every;
    for (int n = 0; n <= 5000; ++n) every.push_back(brute.read(n * kMs));
    Xoshiro256ss rng(5);
    TimeUs t = 0;
    int checked = 0;
    while (true) {
      // Gaps from 0.3 ms up to 400 ms (much longer than the filter windows).
      t += static_cast<TimeUs>(300 + rng.uniform() * (rng.uniform() < 0.2 ? 400000 : 15000));
      if (t > 5000 * kMs) break;
      const auto& r = lazy.read(t);
      const auto& b = every[static_cast<std::size_t>(t / kMs)];
      ASSERT_EQ(r.pressure.sample_index, b.pressure.sample_index);
      if (ft == FilterType::FirstOrder) {
        // catch-up restarts the IIR 40 time constants back: e^-40 relative error
        EXPECT_NEAR(r.pressure.value, b.pressure.value, 1e-6) << "t=" << t;
      } else {
        EXPECT_EQ(r.pressure.value, b.pressure.value) << "t=" << t;  // bit-identical
      }
      EXPECT_EQ(r.pressure.adc_counts, b.pressure.adc_counts);
      EXPECT_EQ(r.temperature.value, b.temperature.value) << "t=" << t;
      ++checked;
    }
    EXPECT_GT(checked, 100);
  }
}

// Without path-dependent elements the lazy result is bit-identical.
TEST(PhysicsSensor, LazyMovingAverageIsBitIdentical) {
  for (FilterType ft : {FilterType::MovingAverage, FilterType::RepeatingAverage}) {
    auto spec = ideal_sensor();
    spec.pressure.filter = {ft, 30};
    spec.pressure.noise_rms = 1500.0;
    auto make = [&] { return Sensor(spec, process({ConstantSpec{5e5}, SineSpec{2e5, 1.7, 0.3}}), 4242); };
    Sensor brute = make(), lazy = make();
    std::vector<double> every;
    for (int n = 0; n <= 3000; ++n) every.push_back(brute.read(n * kMs).pressure.value);
    for (TimeUs t : {TimeUs{7}, 10 * kMs + 500, 11 * kMs, 45 * kMs, 46 * kMs + 999, 500 * kMs, 529 * kMs, 531 * kMs,
                     1999 * kMs, 2000 * kMs, 2029 * kMs + 1, 3000 * kMs})
      EXPECT_EQ(lazy.read(t).pressure.value, every[static_cast<std::size_t>(t / kMs)]) << t;
  }
}

TEST(PhysicsSensor, AdcQuantisesInLsbSteps) {
  // DPS-like: 0..100 psi, 12-bit ADC 0..4095.
  SensorSpec spec = ideal_sensor();
  auto& c = spec.pressure;
  c.range_min = 0;
  c.range_max = to_pa(100, PressureUnit::psi);
  c.adc = AdcSpec::unsigned_bits(12);
  const double lsb = c.range_max / 4095.0;
  Sensor s(spec, process({RampSpec{0, c.range_max, 0, 10.0}}), 1);  // full span in 10 s
  double prev = -1;
  int steps = 0;
  for (int n = 0; n <= 10000; n += 1) {
    const auto& r = s.read(n * kMs).pressure;
    const double k = r.value / lsb;
    EXPECT_NEAR(k, std::round(k), 1e-6) << n;
    EXPECT_EQ(std::lround(k), r.adc_counts);
    if (prev >= 0 && r.value != prev) {
      EXPECT_NEAR(r.value - prev, lsb, 1e-6);  // one LSB at a time
      ++steps;
    }
    prev = r.value;
  }
  EXPECT_EQ(steps, 4095);
  // Saturation at the top code.
  Sensor over(spec, process({ConstantSpec{2 * c.range_max}}), 1);
  const auto& r = over.read(0).pressure;
  EXPECT_EQ(r.adc_counts, 4095);
  EXPECT_TRUE(r.flags & kFlagAdcSaturated);
  // Headroom: codes cover the range +-5 %.
  auto hr = AdcSpec::unsigned_bits(12, 0.05);
  EXPECT_NEAR(hr.code_at_range_min, 4095 * 0.05 / 1.1, 1e-9);
  EXPECT_NEAR(hr.code_at_range_max, 4095 * 1.05 / 1.1, 1e-9);
}

TEST(PhysicsSensor, OutputStepsQuantiseTheReportedValue) {
  // CMP: 0..10 bar with 13-bit output resolution (8192 steps, 1.22 mbar).
  SensorSpec spec = ideal_sensor();
  spec.pressure.range_max = 10e5;
  spec.pressure.adc = AdcSpec::unsigned_bits(20);
  spec.pressure.output_steps = 8192;
  spec.pressure.filter = {FilterType::MovingAverage, 10};
  Sensor s(spec, process({SineSpec{4e5, 0.3, 0}, ConstantSpec{5e5}}), 1);
  const double step = 10e5 / 8192;
  for (int n = 0; n < 2000; n += 7) {
    const double v = s.read(n * kMs).pressure.value;
    EXPECT_NEAR(v / step, std::round(v / step), 1e-6);
  }
}

TEST(PhysicsSensor, OverloadSetsStatusBitsAndCountsEdges) {
  SensorSpec spec = ideal_sensor();
  spec.pressure.range_max = 1e5;
  spec.pressure.adc.code_at_range_max = 1e5;
  // Triangle 0 -> 1.5e5 -> -0.5e5 -> ... (period 4 s): each period one positive, one negative excursion.
  TableSpec tri;
  tri.points = {{0, 0.5e5}, {1, 1.5e5}, {3, -0.5e5}, {4, 0.5e5}};
  tri.loop = true;
  Sensor s(spec, process({TableTermSpec{tri}}), 1);
  bool saw_pos = false, saw_neg = false;
  for (int n = 0; n <= 8000; n += 10) {
    const auto& r = s.read(n * kMs).pressure;
    if (r.truth > 1e5 + 1) {
      EXPECT_EQ(r.status, kStatusPositiveOverload) << n;
      saw_pos = true;
    } else if (r.truth < -1) {
      EXPECT_EQ(r.status, kStatusNegativeOverload) << n;
      saw_neg = true;
    } else if (r.truth > 1 && r.truth < 1e5 - 1) {
      EXPECT_EQ(r.status, 0) << n;
    }
  }
  EXPECT_TRUE(saw_pos && saw_neg);
  EXPECT_EQ(s.counters(Channel::Pressure).positive, 2u);
  EXPECT_EQ(s.counters(Channel::Pressure).negative, 2u);
  s.reset_counters();
  EXPECT_EQ(s.counters(Channel::Pressure).positive, 0u);
}

TEST(PhysicsSensor, OverloadHysteresisPreventsChatter) {
  SensorSpec spec = ideal_sensor();
  spec.pressure.range_max = 1e5;
  spec.pressure.noise_rms = 200;  // noise around the threshold
  auto without = spec;
  spec.pressure.overload.hysteresis = 2000;  // 2 %
  Sensor a(without, process({ConstantSpec{1e5}}), 3), b(spec, process({ConstantSpec{1e5}}), 3);
  for (int n = 0; n < 2000; ++n) {
    a.read(n * kMs);
    b.read(n * kMs);
  }
  EXPECT_GT(a.counters(Channel::Pressure).positive, 100u);
  EXPECT_EQ(b.counters(Channel::Pressure).positive, 1u);
}

TEST(PhysicsSensor, DamageLatchesUntilReplaced) {
  SensorSpec spec = ideal_sensor();
  spec.pressure.range_max = 1e5;
  spec.pressure.overload.safe_max = 3e5;
  // Pressure spike to 4e5 between 1.0 and 1.05 s.
  TableSpec spike;
  spike.points = {{0, 5e4}, {1.0, 5e4}, {1.0, 4e5}, {1.05, 4e5}, {1.05, 5e4}};
  spike.interpolation = Interpolation::Hold;
  Sensor s(spec, process({TableTermSpec{spike}}), 1);
  EXPECT_TRUE(s.read(900 * kMs).pressure.valid());
  EXPECT_FALSE(s.damaged());
  const auto& d = s.read(1020 * kMs).pressure;
  EXPECT_FALSE(d.valid());
  EXPECT_TRUE(d.flags & kFlagDamaged);
  EXPECT_EQ(d.value, 5e4);  // holds the last valid value
  EXPECT_TRUE(s.damaged(Channel::Pressure));
  EXPECT_FALSE(s.damaged(Channel::Temperature));
  EXPECT_FALSE(s.read(5000 * kMs).pressure.valid());  // pressure back to normal: still damaged
  s.reboot(6000 * kMs);                               // a power cycle does not repair it
  EXPECT_FALSE(s.read(6100 * kMs).pressure.valid());
  s.replace(7000 * kMs);  // node replaced: state cleared
  const auto& r = s.read(7100 * kMs).pressure;
  EXPECT_TRUE(r.valid());
  EXPECT_EQ(r.value, 5e4);
  EXPECT_FALSE(s.damaged());
  EXPECT_EQ(r.sample_index, 100);  // sampling restarted at the replacement time
}

TEST(PhysicsSensor, NoiseRmsMatchesConfiguration) {
  SensorSpec spec = ideal_sensor();
  spec.pressure.noise_rms = 250.0;  // 250 codes: quantisation is negligible
  Sensor s(spec, process({ConstantSpec{5e5}}), 2024);
  double sum = 0, sum2 = 0;
  const int n = 10000;
  for (int i = 0; i < n; ++i) {
    const double v = s.read(i * kMs).pressure.value - 5e5;
    sum += v;
    sum2 += v * v;
  }
  const double mean = sum / n;
  const double rms = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(rms, 250.0, 250.0 * 0.05);
  EXPECT_NEAR(mean, 0.0, 10.0);
  // A different seed gives a different series, the same seed the same one.
  Sensor a(spec, process({ConstantSpec{5e5}}), 1), b(spec, process({ConstantSpec{5e5}}), 1),
      c(spec, process({ConstantSpec{5e5}}), 2);
  int diff = 0;
  for (int i = 0; i < 100; ++i) {
    const double va = a.read(i * kMs).pressure.value;
    EXPECT_EQ(va, b.read(i * kMs).pressure.value);
    diff += va != c.read(i * kMs).pressure.value;
  }
  EXPECT_GT(diff, 90);
}

TEST(PhysicsSensor, ErrorStaysWithinTotalErrorBandOverTemperatureRange) {
  // Gems 9000 style: 100 psi, TEB +-2 %FS over 4..60 degC, accuracy 0.25 %FS (nl + hysteresis), noise.
  const double span = to_pa(100, PressureUnit::psi);
  double max_err = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    SensorSpec spec = ideal_sensor();
    auto& c = spec.pressure;
    c.range_max = span;
    c.adc = AdcSpec::unsigned_bits(12);
    c.noise_rms = 0.00033 * span;
    c.errors.nonlinearity = 0.0015 * span;
    c.errors.hysteresis = 0.001 * span;
    c.errors.total_error_band = 0.02 * span;
    c.errors.reference_temperature_k = 298.15;
    c.errors.compensated_min_k = 277.15;
    c.errors.compensated_max_k = 333.15;
    for (double tk : {277.15, 290.0, 298.15, 315.0, 333.15}) {
      for (double frac : {0.0, 0.1, 0.25, 0.5, 0.75, 0.9, 1.0}) {
        Sensor s(spec, process({ConstantSpec{frac * span}}, {ConstantSpec{tk}}), seed);
        for (int n = 0; n < 50; ++n) {
          const double err = std::abs(s.read(n * kMs).pressure.value - frac * span);
          max_err = std::max(max_err, err);
          ASSERT_LE(err, 0.02 * span) << "seed " << seed << " T " << tk << " p " << frac;
        }
      }
    }
  }
  EXPECT_GT(max_err, 0.002 * span);  // the per-instance errors are really there
  // The draw is per seed: different instances differ.
  SensorSpec spec = ideal_sensor();
  spec.pressure.errors.total_error_band = 1000;
  Sensor a(spec, process({ConstantSpec{1}}), 1), b(spec, process({ConstantSpec{1}}), 2);
  EXPECT_NE(a.effective_errors(Channel::Pressure).zero_offset, b.effective_errors(Channel::Pressure).zero_offset);
}

TEST(PhysicsSensor, ExplicitThermalNonlinearityAndHysteresisErrors) {
  SensorSpec spec = ideal_sensor();
  auto& e = spec.pressure.errors;
  e.zero_offset = 100;
  e.span_error = 0.001;
  e.thermal_zero_per_k = 20;
  e.thermal_span_per_k = 1e-4;
  e.nonlinearity = 300;
  e.reference_temperature_k = 298.15;
  // At T = 308.15 (dT = 10), p = 5e5 (mid-span): 100 + 200 + 5e5 * (0.001 + 0.001) + 300 = 1600.
  Sensor s(spec, process({ConstantSpec{5e5}}, {ConstantSpec{308.15}}), 1);
  EXPECT_NEAR(s.read(0).pressure.value - 5e5, 1600, 1);

  SensorSpec h = ideal_sensor();
  h.pressure.errors.hysteresis = 2000;  // +-1000
  TableSpec updown;
  updown.points = {{0, 1e5}, {1, 5e5}, {2, 1e5}};
  Sensor hs(h, process({TableTermSpec{updown}}), 1);
  for (int n = 0; n < 500; n += 10) hs.read(n * kMs);
  const double up = hs.read(500 * kMs).pressure.value;  // rising through 3e5
  for (int n = 510; n < 1500; n += 10) hs.read(n * kMs);
  const double down = hs.read(1500 * kMs).pressure.value;  // falling through 3e5
  EXPECT_NEAR(up, 3e5 - 1000, 1);
  EXPECT_NEAR(down, 3e5 + 1000, 1);
}

TEST(PhysicsSensor, ResponseTimeIsFirstOrderLag) {
  SensorSpec spec = ideal_sensor();
  spec.pressure.response_time_constant_s = 0.010;
  Sensor s(spec, process({RampSpec{0, 1e5, 0.1, 0}}), 1);
  s.read(99 * kMs);
  const double a = 1 - std::exp(-0.1);  // per-sample smoothing at 1 kHz, tau 10 ms
  // After k samples at the new level: 1 - (1 - a)^k ; after 10 samples ~ 63 %.
  const double v = s.read(109 * kMs).pressure.value;
  EXPECT_NEAR(v, 1e5 * (1 - std::pow(1 - a, 10)), 1.0);
  EXPECT_NEAR(v / 1e5, 0.632, 0.01);
}

TEST(PhysicsSensor, RuntimeFilterChangeRestartsTheBuffer) {
  auto spec = ideal_sensor();
  spec.pressure.filter = {FilterType::MovingAverage, 10};
  spec.pressure.filter_capacity = 100;
  Sensor s(spec, process({RampSpec{0, 1e6, 0, 1.0}}), 1);  // 1000 Pa per ms
  s.read(50 * kMs);
  s.set_filter(Channel::Pressure, {FilterType::MovingAverage, 100});
  // Buffer restarts with sample 51 (51000) as its history.
  const double v = s.read(52 * kMs).pressure.value;
  EXPECT_DOUBLE_EQ(v, (98 * 51000.0 + 51000 + 52000) / 100.0);
  EXPECT_EQ(s.filter(Channel::Pressure).length, 100u);
}

TEST(PhysicsSensor, DisabledChannelAndSampleHook) {
  SensorSpec spec = ideal_sensor();
  spec.temperature.enabled = false;
  spec.pressure.catch_up_samples = 1000;  // observe every sample, even with sparse reads
  Sensor s(spec, process({ConstantSpec{2e5}}, {ConstantSpec{310}}), 1);
  struct Ctx {
    int samples = 0;
    double last = 0;
  } ctx;
  s.set_sample_hook(
      [](void* c, Channel ch, const ChannelReading& r) {
        auto* x = static_cast<Ctx*>(c);
        EXPECT_EQ(ch, Channel::Pressure);
        ++x->samples;
        x->last = r.value;
      },
      &ctx);
  const auto& r = s.read(19 * kMs);
  EXPECT_EQ(ctx.samples, 20);
  EXPECT_EQ(ctx.last, 2e5);
  EXPECT_EQ(r.temperature.value, 310);
  EXPECT_TRUE(r.temperature.flags & kFlagDisabled);
  // Same time again: cached, no new samples.
  s.read(19 * kMs);
  EXPECT_EQ(ctx.samples, 20);
}

TEST(PhysicsSensor, ReadDoesNotAllocate) {
  if (!kCountingNew) GTEST_SKIP() << "allocation counting disabled under AddressSanitizer";
  auto spec = ideal_sensor();
  spec.pressure.filter = {FilterType::MovingAverage, 30};
  spec.pressure.noise_rms = 100;
  spec.pressure.errors.hysteresis = 100;
  spec.pressure.response_time_constant_s = 0.002;
  spec.temperature.filter = {FilterType::RepeatingAverage, 50};
  ProcessSpec ps;
  SecondOrderSpec so;
  so.setpoint.points = {{0, 1e5}, {1, 5e5}};
  so.setpoint.loop = true;
  so.setpoint.period_s = 3;
  ps.pressure = {so, PulsationSpec::piston_pump(1450, 3, 4000, 3), OrnsteinUhlenbeckSpec{0, 10, 1000}};
  ps.temperature = {ConstantSpec{300}, RandomWalkSpec{0, 0.01}};
  FaultSet faults;
  FaultSpec drift;
  drift.kind = FaultKind::Drift;
  drift.drift_per_s = 100;
  drift.timing.at_us = 1000 * kMs;
  drift.timing.duration_us = 500 * kMs;
  drift.timing.period_us = 2000 * kMs;
  faults.add(drift, 0);
  FaultSpec spikes;
  spikes.kind = FaultKind::Spikes;
  spikes.spike_rate_hz = 50;
  spikes.spike_amplitude = 1e4;
  faults.add(spikes, 0);
  Sensor s(spec, ProcessModel(ps, 3), 5, &faults);
  int hook_calls = 0;
  s.set_sample_hook([](void* c, Channel, const ChannelReading&) { ++*static_cast<int*>(c); }, &hook_calls);
  s.read(0);
  const long before = g_allocations.load();
  double acc = 0;
  for (int i = 1; i <= 20000; ++i) acc += s.read(i * 7 * kMs / 3).pressure.value;
  FaultEdge e;
  while (faults.poll(50000 * kMs, e)) acc += e.time_us;
  const long after = g_allocations.load();
  EXPECT_EQ(after - before, 0);
  EXPECT_GT(hook_calls, 40000);
  EXPECT_TRUE(std::isfinite(acc));
  // The counter itself works.
  auto* p = new int(3);
  EXPECT_EQ(g_allocations.load(), after + 1);
  delete p;
}

TEST(PhysicsSensor, InvalidSpecIsRejected) {
  auto spec = ideal_sensor();
  spec.pressure.range_max = spec.pressure.range_min;
  EXPECT_FALSE(validate(spec).empty());
  EXPECT_THROW(Sensor(spec, ProcessModel(), 1), std::invalid_argument);
  spec = ideal_sensor();
  spec.pressure.filter = {FilterType::FirstOrder, 1, 0.0};
  EXPECT_THROW(Sensor(spec, ProcessModel(), 1), std::invalid_argument);
}

TEST(PhysicsSensor, SampleGridIsExactOverLongRunsAndOddRates) {
  auto spec = ideal_sensor();
  Sensor s(spec, process({ConstantSpec{1e5}}), 1);
  const TimeUs day = 86400LL * 1000000;
  const auto& r = s.read(200 * day + 999);  // beyond the 64-bit fast path of index arithmetic
  EXPECT_EQ(r.pressure.sample_index, 200LL * 86400 * 1000);
  EXPECT_EQ(r.pressure.sample_time_us, 200 * day);
  spec.pressure.sample_rate_hz = 3000;  // 333.33 us period
  spec.temperature.sample_rate_hz = 10;
  Sensor o(spec, process({ConstantSpec{1e5}}), 1, nullptr, 5000);  // booted at 5 ms
  EXPECT_EQ(o.read(4999).pressure.sample_index, -1);               // before boot: nothing sampled
  const auto& q = o.read(5000 + 1000);
  EXPECT_EQ(q.pressure.sample_index, 3);
  EXPECT_EQ(q.pressure.sample_time_us, 6000);
  EXPECT_EQ(q.temperature.sample_index, 0);
  const auto& q2 = o.read(5000 + 999999);
  EXPECT_EQ(q2.pressure.sample_index, 2999);
  EXPECT_EQ(q2.pressure.sample_time_us, 5000 + 999666);
  EXPECT_EQ(q2.temperature.sample_index, 9);
}

TEST(PhysicsSensor, FilterWindowFromTime) {
  // CMP: pressure filter 1000 ms at 1 kHz -> 1000 samples; temperature 0.1 s units at 10 Hz.
  EXPECT_EQ(FilterSpec::from_time(FilterType::MovingAverage, 1.0, 1000).length, 1000u);
  EXPECT_EQ(FilterSpec::from_time(FilterType::MovingAverage, 0.0004, 1000).length, 1u);
  EXPECT_EQ(FilterSpec::from_time(FilterType::MovingAverage, 6553.5, 10).length, 65535u);
  const auto f = FilterSpec::from_time(FilterType::FirstOrder, 0.25, 100);
  EXPECT_EQ(f.time_constant_s, 0.25);
  // A 1000-sample window read every 10 ms equals brute force exactly.
  auto spec = ideal_sensor();
  spec.pressure.filter = FilterSpec::from_time(FilterType::MovingAverage, 1.0, 1000);
  spec.pressure.noise_rms = 500;
  Sensor brute(spec, process({SineSpec{1e5, 0.7, 0}, ConstantSpec{5e5}}), 3);
  Sensor lazy(spec, process({SineSpec{1e5, 0.7, 0}, ConstantSpec{5e5}}), 3);
  for (int n = 0; n <= 3000; ++n) {
    const double b = brute.read(n * kMs).pressure.value;
    if (n % 10 == 0 || n == 2345) {
      EXPECT_EQ(lazy.read(n * kMs).pressure.value, b) << n;
    }
  }
  ProcessModel m;
  EXPECT_EQ(m.at_us(1500000).pressure_pa, m.at(1.5).pressure_pa);
}

// ---- steadiness: what the next read gives, without reading

namespace {
// A realistic pressure channel: 0..10 bar, 16-bit ADC with headroom, 1 mbar
// noise, static and thermal errors, a 2 % hysteresis loop, a moving average.
SensorSpec transmitter() {
  SensorSpec s = ideal_sensor();
  ChannelSpec& p = s.pressure;
  p.range_min = 0;
  p.range_max = 10e5;
  p.adc = AdcSpec::unsigned_bits(16, 0.1);
  p.noise_rms = 100;
  p.errors.zero_offset = 300;
  p.errors.span_error = 0.002;
  p.errors.thermal_zero_per_k = 5;
  p.errors.hysteresis = 2000;
  p.filter = {FilterType::MovingAverage, 8, 0};
  return s;
}
}  // namespace

// Whatever a single later read gives lies in the bounds, with the status said
// (drifting OU process, sine temperature, 300 seeds, reads up to 200 s on).
TEST(PhysicsSensor, ASteadyChannelReadsWithinItsBounds) {
  int sure = 0;
  for (std::uint64_t seed = 1; seed <= 300; ++seed) {
    Sensor s(
        transmitter(),
        process({ConstantSpec{5e5}, OrnsteinUhlenbeckSpec{0, 30, 1e4}}, {ConstantSpec{295}, SineSpec{3, 1.0 / 600, 0}}),
        seed);
    Xoshiro256ss rng(seed);
    const TimeUs t = TimeUs(rng.uniform(0.05, 2.0) * 1e6);
    s.read(t);
    const Steadiness st = s.steadiness(Channel::Pressure, t);
    if (st.until <= t) continue;
    ++sure;
    const TimeUs later = t + 1 + TimeUs(rng.uniform() * std::min<double>(200e6, double(st.until - t - 1)));
    const ChannelReading& r = s.read(later).pressure;
    EXPECT_GE(r.value, st.lo) << "seed " << seed;
    EXPECT_LE(r.value, st.hi) << "seed " << seed;
    EXPECT_EQ(r.status, st.status) << "seed " << seed;
  }
  EXPECT_EQ(sure, 300);  // 5 bar +- OU is far from 0 and 10 bar
}

// Near a limit, under a measurement fault in force, before any sample and
// for a second-order process nothing is sure; a fault to come bounds it.
TEST(PhysicsSensor, NothingIsSureNearALimitOrUnderAFault) {
  Sensor near(transmitter(), process({ConstantSpec{9.99e5}, OrnsteinUhlenbeckSpec{0, 30, 2e3}}), 1);
  EXPECT_EQ(near.steadiness(Channel::Pressure, 0).until, 0);  // no sample yet
  near.read(1000 * kMs);
  EXPECT_EQ(near.steadiness(Channel::Pressure, 1000 * kMs).until, 1000 * kMs);

  FaultSet faults;
  FaultSpec open;
  open.kind = FaultKind::SensorOpen;
  open.timing.at_us = 3000 * kMs;
  open.timing.duration_us = 1000 * kMs;
  faults.add(open, 0);
  Sensor s(transmitter(), process({ConstantSpec{5e5}}), 1, &faults);
  s.read(1000 * kMs);
  EXPECT_EQ(s.steadiness(Channel::Pressure, 1000 * kMs).until, 3000 * kMs);
  EXPECT_EQ(s.steadiness(Channel::Temperature, 1000 * kMs).until, kNever);  // the fault is the pressure channel's
  s.read(3500 * kMs);
  EXPECT_EQ(s.steadiness(Channel::Pressure, 3500 * kMs).until, 3500 * kMs);
  EXPECT_EQ(s.read(3500 * kMs).pressure.status, kStatusInvalid);
  s.read(4100 * kMs);  // after it: sure again, and valid
  const Steadiness after = s.steadiness(Channel::Pressure, 4100 * kMs);
  EXPECT_EQ(after.until, kNever);
  EXPECT_EQ(after.status, 0);

  SecondOrderSpec ringing;
  ringing.setpoint.points = {{0, 5e5}};
  Sensor second(transmitter(), process({ringing}), 1);
  second.read(1000 * kMs);
  EXPECT_EQ(second.steadiness(Channel::Pressure, 1000 * kMs).until, 1000 * kMs);
}

// A damaged sensor stays not valid with its last valid value held.
TEST(PhysicsSensor, ADamagedChannelIsSureToStayInvalid) {
  SensorSpec spec = transmitter();
  spec.pressure.overload.safe_max = 20e5;
  Sensor s(spec, process({RampSpec{5e5, 25e5, 1.0, 1.0}}), 1);
  s.read(500 * kMs);
  EXPECT_EQ(s.steadiness(Channel::Pressure, 500 * kMs).until, 1000 * kMs);  // the 0.5 s horizon: then it may be damaged
  s.read(1000 * kMs);
  EXPECT_EQ(s.steadiness(Channel::Pressure, 1000 * kMs).until, 1000 * kMs);
  s.read(3000 * kMs);
  ASSERT_TRUE(s.damaged());
  const Steadiness st = s.steadiness(Channel::Pressure, 3000 * kMs);
  EXPECT_EQ(st.until, kNever);
  EXPECT_EQ(st.status, kStatusInvalid);
  EXPECT_DOUBLE_EQ(st.lo, s.read(3000 * kMs).pressure.value);
  EXPECT_DOUBLE_EQ(st.lo, st.hi);
}
