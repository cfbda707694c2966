// Process models ("the truth") against their closed forms.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "physics/process.hpp"
#include "physics/table.hpp"

using namespace cansim::physics;

namespace {

constexpr double kPi = 3.14159265358979323846;

ProcessModel pressure_model(TermSpec term, std::uint64_t seed = 1) {
  ProcessSpec s;
  s.pressure.push_back(std::move(term));
  return ProcessModel(s, seed);
}

double p_at(ProcessModel& m, double t) { return m.at(t).pressure_pa; }

TableSpec table(std::vector<TablePoint> pts, Interpolation i = Interpolation::Linear, bool loop = false,
                double period = 0) {
  TableSpec t;
  t.points = std::move(pts);
  t.interpolation = i;
  t.loop = loop;
  t.period_s = period;
  return t;
}

}  // namespace

TEST(PhysicsModels, ConstantAndRamp) {
  auto c = pressure_model(ConstantSpec{2.5e5});
  EXPECT_EQ(p_at(c, 0), 2.5e5);
  EXPECT_EQ(p_at(c, 1e6), 2.5e5);

  auto r = pressure_model(RampSpec{1e5, 5e5, 10.0, 40.0});
  EXPECT_DOUBLE_EQ(p_at(r, 0.0), 1e5);
  EXPECT_DOUBLE_EQ(p_at(r, 10.0), 1e5);
  EXPECT_DOUBLE_EQ(p_at(r, 20.0), 2e5);
  EXPECT_DOUBLE_EQ(p_at(r, 30.0), 3e5);
  EXPECT_DOUBLE_EQ(p_at(r, 50.0), 5e5);
  EXPECT_DOUBLE_EQ(p_at(r, 500.0), 5e5);

  auto step = pressure_model(RampSpec{1.0, 2.0, 3.0, 0.0});
  EXPECT_EQ(p_at(step, 2.999), 1.0);
  EXPECT_EQ(p_at(step, 3.0), 2.0);
}

TEST(PhysicsModels, TableLinearAndHoldOnce) {
  auto lin = pressure_model(TableTermSpec{table({{1, 10}, {3, 30}, {3, 0}, {5, 20}})});
  EXPECT_DOUBLE_EQ(p_at(lin, 0.0), 10);  // before the first point: first value
  EXPECT_DOUBLE_EQ(p_at(lin, 2.0), 20);
  EXPECT_DOUBLE_EQ(p_at(lin, 2.999), 29.99);
  EXPECT_DOUBLE_EQ(p_at(lin, 3.0), 0);  // jump (two points at t = 3)
  EXPECT_DOUBLE_EQ(p_at(lin, 4.0), 10);
  EXPECT_DOUBLE_EQ(p_at(lin, 99.0), 20);  // hold after the end

  auto hold = pressure_model(TableTermSpec{table({{1, 10}, {3, 30}, {5, 20}}, Interpolation::Hold)});
  EXPECT_EQ(p_at(hold, 0.5), 10);
  EXPECT_EQ(p_at(hold, 2.9), 10);
  EXPECT_EQ(p_at(hold, 3.0), 30);
  EXPECT_EQ(p_at(hold, 4.99), 30);
  EXPECT_EQ(p_at(hold, 7.0), 20);
}

TEST(PhysicsModels, TableLooped) {
  // Period = span (4 s): 0 -> 10 over 2 s, 10 -> 0 over 2 s, repeat.
  auto tri = pressure_model(TableTermSpec{table({{0, 0}, {2, 10}, {4, 0}}, Interpolation::Linear, true)});
  EXPECT_NEAR(p_at(tri, 1.0), 5, 1e-12);
  EXPECT_NEAR(p_at(tri, 3.0), 5, 1e-12);
  EXPECT_NEAR(p_at(tri, 4.5), 2.5, 1e-12);
  EXPECT_NEAR(p_at(tri, 402.0), 10, 1e-9);
  // Longer period: linear return from the last to the first value in the gap.
  auto gap = pressure_model(TableTermSpec{table({{0, 0}, {1, 10}}, Interpolation::Linear, true, 3.0)});
  EXPECT_NEAR(p_at(gap, 2.0), 5, 1e-12);
  EXPECT_NEAR(p_at(gap, 3.5), 5, 1e-12);
  // Hold loop with a gap holds the last value.
  auto hl = pressure_model(TableTermSpec{table({{0, 1}, {1, 2}}, Interpolation::Hold, true, 3.0)});
  EXPECT_EQ(p_at(hl, 0.5), 1);
  EXPECT_EQ(p_at(hl, 2.5), 2);
  EXPECT_EQ(p_at(hl, 3.2), 1);
  EXPECT_EQ(p_at(hl, 4.2), 2);
}

TEST(PhysicsModels, TableCsvParsing) {
  std::vector<TablePoint> pts;
  std::string err;
  ASSERT_TRUE(parse_table_csv("# comment\ntime_s,pressure_bar\n0,1.0\n1.5; 2.5\n3\t4\n", pts, &err, 1.0, 1e5)) << err;
  ASSERT_EQ(pts.size(), 3u);
  EXPECT_EQ(pts[1].t_s, 1.5);
  EXPECT_EQ(pts[1].value, 2.5e5);
  EXPECT_EQ(pts[2].value, 4e5);
  EXPECT_FALSE(parse_table_csv("0,1\n2,x\n", pts, &err));
  EXPECT_NE(err.find("line 2"), std::string::npos);
  EXPECT_FALSE(parse_table_csv("0,1\n2,1\n1,1\n", pts, &err));  // time backwards
  EXPECT_FALSE(parse_table_csv("# nothing\n", pts, &err));
  // Temperature in degC converted with an offset.
  ASSERT_TRUE(parse_table_csv("0 20\n10 30\n", pts, &err, 1.0, 1.0, 273.15));
  EXPECT_DOUBLE_EQ(pts[1].value, 303.15);
}

TEST(PhysicsModels, SineAndPulse) {
  auto s = pressure_model(SineSpec{3.0, 2.0, 0.5});
  for (double t : {0.0, 0.1, 0.37, 12.345, 86400.123})
    EXPECT_NEAR(p_at(s, t), 3.0 * std::sin(2 * kPi * 2.0 * t + 0.5), 1e-9) << t;

  PulseSpec ps{1.0, 5.0, 10.0, 0.3, 2.0, 1.0, 2.0};  // low 1, high 5, period 10, high from rise start for 3 s
  auto p = pressure_model(ps);
  EXPECT_EQ(p_at(p, 1.0), 1.0);          // before delay
  EXPECT_DOUBLE_EQ(p_at(p, 2.5), 3.0);   // middle of the 1 s rise
  EXPECT_EQ(p_at(p, 4.0), 5.0);          // high
  EXPECT_DOUBLE_EQ(p_at(p, 6.0), 3.0);   // 1 s into the 2 s fall (fall starts at 5): midway
  EXPECT_EQ(p_at(p, 8.0), 1.0);          // low
  EXPECT_DOUBLE_EQ(p_at(p, 12.5), 3.0);  // next period
  auto sq = pressure_model(PulseSpec{-1.0, 1.0, 2.0, 0.5, 0.0, 0.0, 0.0});
  EXPECT_EQ(p_at(sq, 0.0), 1.0);
  EXPECT_EQ(p_at(sq, 0.99), 1.0);
  EXPECT_EQ(p_at(sq, 1.0), -1.0);
  EXPECT_EQ(p_at(sq, 2.5), 1.0);
}

TEST(PhysicsModels, PumpPulsationIsSumOfHarmonics) {
  PulsationSpec ps;
  ps.shaft_hz = 1450.0 / 60.0;
  ps.harmonics = {{3, 2000.0, 0.3}, {6, 800.0, -1.0}, {9, 300.0, 2.0}, {1.5, 100.0, 0.7}};
  auto m = pressure_model(ps);
  for (double t : {0.0, 0.0123, 0.5, 3.3333, 1000.01}) {
    double expect = 0;
    for (const auto& h : ps.harmonics)
      expect += h.amplitude * std::sin(2 * kPi * h.order * ps.shaft_hz * t + h.phase_rad);
    EXPECT_NEAR(p_at(m, t), expect, 1e-6) << t;
  }
  auto pp = PulsationSpec::piston_pump(1500, 3, 1000.0, 3);
  EXPECT_EQ(pp.shaft_hz, 25.0);
  ASSERT_EQ(pp.harmonics.size(), 3u);
  EXPECT_EQ(pp.harmonics[2].order, 9.0);
  EXPECT_DOUBLE_EQ(pp.harmonics[2].amplitude, 1000.0 / 3);
}

TEST(PhysicsModels, FirstOrderStepAndRamp) {
  FirstOrderSpec f;
  f.setpoint = table({{0, 1e5}, {2, 3e5}}, Interpolation::Hold);
  f.time_constant_s = 0.5;
  auto m = pressure_model(f);
  EXPECT_DOUBLE_EQ(p_at(m, 1.0), 1e5);
  for (double t : {2.0, 2.1, 2.5, 3.0, 5.0, 50.0})
    EXPECT_NEAR(p_at(m, t), 1e5 + 2e5 * (1 - std::exp(-(t - 2) / 0.5)), 1e-6) << t;

  // Ramp setpoint: 0 until 1 s, then 10/s until 3 s, then hold.
  FirstOrderSpec r;
  r.setpoint = table({{1, 0}, {3, 20}});
  r.time_constant_s = 0.4;
  auto mr = pressure_model(r);
  auto ramp_resp = [](double a) { return a <= 0 ? 0.0 : a - 0.4 * (1 - std::exp(-a / 0.4)); };
  for (double t : {0.5, 1.2, 2.0, 3.0, 3.3, 4.0, 10.0}) {
    const double expect = 10 * (ramp_resp(t - 1) - ramp_resp(t - 3));
    EXPECT_NEAR(p_at(mr, t), expect, 1e-9) << t;
  }
}

TEST(PhysicsModels, FirstOrderInitialValueIsNewtonCooling) {
  FirstOrderSpec f;
  f.setpoint = table({{0, 293.15}});
  f.time_constant_s = 100;
  f.initial = 353.15;
  ProcessSpec s;
  s.temperature.push_back(f);
  ProcessModel m(s, 1);
  for (double t : {0.0, 10.0, 100.0, 1000.0})
    EXPECT_NEAR(m.at(t).temperature_k, 293.15 + 60 * std::exp(-t / 100), 1e-9) << t;
}

TEST(PhysicsModels, SecondOrderStepOvershootsAndRings) {
  const double fn = 2.0, zeta = 0.2;
  const double w = 2 * kPi * fn, wd = w * std::sqrt(1 - zeta * zeta);
  SecondOrderSpec s;
  s.setpoint = table({{0, 0}, {1, 1e5}}, Interpolation::Hold);
  s.natural_frequency_hz = fn;
  s.damping = zeta;
  auto m = pressure_model(s);
  auto closed = [&](double a) {
    return 1e5 *
           (1 - std::exp(-zeta * w * a) * (std::cos(wd * a) + zeta / std::sqrt(1 - zeta * zeta) * std::sin(wd * a)));
  };
  for (double t : {1.0, 1.05, 1.1, 1.3, 2.0, 4.0}) EXPECT_NEAR(p_at(m, t), closed(t - 1), 1e-6) << t;
  // Peak at pi / wd with overshoot exp(-pi zeta / sqrt(1 - zeta^2)).
  const double peak = p_at(m, 1 + kPi / wd);
  EXPECT_NEAR(peak, 1e5 * (1 + std::exp(-kPi * zeta / std::sqrt(1 - zeta * zeta))), 1e-6);
  EXPECT_GT(peak, 1.5e5);
  EXPECT_LT(p_at(m, 1 + 2 * kPi / wd), 1e5);  // rings below after one period

  // Critically damped and overdamped: no overshoot, closed forms.
  for (double z : {1.0, 3.0}) {
    SecondOrderSpec c = s;
    c.damping = z;
    auto mc = pressure_model(c);
    for (double a : {0.0, 0.05, 0.2, 0.5, 2.0}) {
      double expect;
      if (z == 1.0) {
        expect = 1e5 * (1 - std::exp(-w * a) * (1 + w * a));
      } else {
        const double r = std::sqrt(z * z - 1), p1 = w * (z - r), p2 = w * (z + r);
        expect = 1e5 * (1 - (p2 * std::exp(-p1 * a) - p1 * std::exp(-p2 * a)) / (p2 - p1));
      }
      EXPECT_NEAR(p_at(mc, 1 + a), expect, 1e-5) << z << " " << a;
      EXPECT_LE(p_at(mc, 1 + a), 1e5 + 1e-6);
    }
  }
}

// Independent check of the superposition for a looped piecewise-linear setpoint: integrate the ODE.
TEST(PhysicsModels, SecondOrderMatchesNumericalIntegrationOnLoopedRamps) {
  SecondOrderSpec s;
  s.setpoint = table({{0.5, 0}, {1.0, 10}, {1.0, 4}, {2.0, 8}}, Interpolation::Linear, true, 2.5);
  s.natural_frequency_hz = 1.3;
  s.damping = 0.35;
  auto m = pressure_model(s);
  Table sp(s.setpoint);
  const double w = 2 * kPi * s.natural_frequency_hz, z = s.damping;
  // RK4 on y'' = w^2 (u - y) - 2 z w y', starting at rest at u(0).
  double y = sp.value(0), v = 0, t = 0;
  const double h = 1e-4;
  auto acc = [&](double tt, double yy, double vv) { return w * w * (sp.value(tt) - yy) - 2 * z * w * vv; };
  for (double check : {0.7, 1.0, 1.9, 3.1, 6.0, 12.34}) {
    while (t + h <= check + 1e-12) {
      const double k1y = v, k1v = acc(t, y, v);
      const double k2y = v + 0.5 * h * k1v, k2v = acc(t + 0.5 * h, y + 0.5 * h * k1y, v + 0.5 * h * k1v);
      const double k3y = v + 0.5 * h * k2v, k3v = acc(t + 0.5 * h, y + 0.5 * h * k2y, v + 0.5 * h * k2v);
      const double k4y = v + h * k3v, k4v = acc(t + h, y + h * k3y, v + h * k3v);
      y += h / 6 * (k1y + 2 * k2y + 2 * k3y + k4y);
      v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
      t += h;
    }
    // RK4 across the setpoint jumps is first-order accurate there: tolerance 0.01 of a 10-unit swing.
    EXPECT_NEAR(p_at(m, t), y, 0.01) << check;
  }
}

TEST(PhysicsModels, GasVolumeFollowsTemperature) {
  ProcessSpec s;
  GasVolumeSpec g;
  g.initial_pressure_pa = 2e5;
  g.initial_temperature_k = 353.15;
  g.ambient_k = table({{0, 293.15}});
  g.time_constant_s = 600;
  add_gas_volume(s, g);
  ProcessModel m(s, 3);
  for (double t : {0.0, 60.0, 600.0, 3600.0}) {
    const auto q = m.at(t);
    const double tk = 293.15 + 60 * std::exp(-t / 600);
    EXPECT_NEAR(q.temperature_k, tk, 1e-9);
    EXPECT_NEAR(q.pressure_pa, 2e5 * tk / 353.15, 1e-6);
    EXPECT_NEAR(q.pressure_pa / q.temperature_k, 2e5 / 353.15, 1e-9);  // p/T constant
  }
}

TEST(PhysicsModels, CompositionIsTheSumOfTerms) {
  SecondOrderSpec so;
  so.setpoint = table({{0, 1e5}, {5, 4e5}}, Interpolation::Hold);
  so.natural_frequency_hz = 0.5;
  so.damping = 0.4;
  auto pul = PulsationSpec::piston_pump(1450, 3, 5000.0, 3);
  ProcessSpec all;
  all.pressure = {so, pul, ConstantSpec{-2000.0}};
  all.temperature = {ConstantSpec{300.0}, SineSpec{5.0, 0.01, 0.0}};
  ProcessModel m(all, 9);
  auto a = pressure_model(so), b = pressure_model(pul);
  for (double t : {0.0, 4.0, 5.5, 7.25, 30.0}) {
    const auto q = m.at(t);
    EXPECT_NEAR(q.pressure_pa, p_at(a, t) + p_at(b, t) - 2000.0, 1e-6);
    EXPECT_NEAR(q.temperature_k, 300.0 + 5.0 * std::sin(2 * kPi * 0.01 * t), 1e-9);
  }
}

TEST(PhysicsModels, StochasticTermsAreDeterministicPerSeed) {
  ProcessSpec s;
  s.pressure = {ConstantSpec{1e5}, OrnsteinUhlenbeckSpec{0.0, 30.0, 500.0, kNaN}, RandomWalkSpec{0.0, 20.0, 0.0}};
  ProcessModel a(s, 42), b(s, 42), c(s, 43);
  int differ = 0;
  for (int i = 1; i <= 200; ++i) {
    const double t = i * 0.37;
    const double pa = a.at(t).pressure_pa, pb = b.at(t).pressure_pa, pc = c.at(t).pressure_pa;
    EXPECT_EQ(pa, pb);
    differ += pa != pc;
  }
  EXPECT_GT(differ, 190);
  EXPECT_TRUE(a.has_stochastic_terms());
  // reset() replays the same series.
  ProcessModel d(s, 42);
  std::vector<double> first;
  for (int i = 1; i <= 20; ++i) first.push_back(d.at(i * 0.5).pressure_pa);
  d.reset();
  for (int i = 1; i <= 20; ++i) EXPECT_EQ(d.at(i * 0.5).pressure_pa, first[i - 1]);
  // Never runs backwards.
  const double last = d.at(100.0).pressure_pa;
  EXPECT_EQ(d.at(50.0).pressure_pa, last);
}

TEST(PhysicsModels, OrnsteinUhlenbeckExactAr1Statistics) {
  // Stationary sd 2, tau 1 s, sampled every 0.5 s: lag-1 correlation exp(-0.5), variance 4,
  // independent of the step (exact discretisation): check with two different dt.
  for (double dt : {0.5, 0.05}) {
    ProcessSpec s;
    s.pressure = {OrnsteinUhlenbeckSpec{10.0, 1.0, 2.0, 10.0}};
    ProcessModel m(s, 7);
    const int n = 200000;
    std::vector<double> x(n);
    for (int i = 0; i < n; ++i) x[i] = m.at((i + 1) * dt).pressure_pa;
    const double mean = std::accumulate(x.begin(), x.end(), 0.0) / n;
    double var = 0, cov = 0;
    for (int i = 0; i < n; ++i) var += (x[i] - mean) * (x[i] - mean);
    for (int i = 1; i < n; ++i) cov += (x[i] - mean) * (x[i - 1] - mean);
    var /= n;
    cov /= (n - 1);
    const double tol = dt < 0.1 ? 0.1 : 0.05;  // fewer effective samples at small dt
    EXPECT_NEAR(mean, 10.0, 0.1) << dt;
    EXPECT_NEAR(var, 4.0, 4.0 * tol) << dt;
    EXPECT_NEAR(cov / var, std::exp(-dt / 1.0), 0.01) << dt;
  }
}

TEST(PhysicsModels, RandomWalkVarianceGrowsLinearly) {
  // Var[x(t)] = sigma^2 t, independent of the query step.
  const int runs = 4000;
  double sum2_fine = 0, sum2_coarse = 0;
  for (int r = 0; r < runs; ++r) {
    ProcessSpec s;
    s.pressure = {RandomWalkSpec{0.0, 3.0, 0.0}};
    ProcessModel fine(s, 1000 + r), coarse(s, 50000 + r);
    double xf = 0;
    for (int i = 1; i <= 100; ++i) xf = fine.at(i * 0.04).pressure_pa;  // t = 4
    const double xc = coarse.at(4.0).pressure_pa;
    sum2_fine += xf * xf;
    sum2_coarse += xc * xc;
  }
  EXPECT_NEAR(sum2_fine / runs, 9.0 * 4.0, 36.0 * 0.07);
  EXPECT_NEAR(sum2_coarse / runs, 9.0 * 4.0, 36.0 * 0.07);
  // Drift and clamping.
  ProcessSpec s;
  s.pressure = {RandomWalkSpec{0.0, 0.0, 2.0, -1.0, 5.0}};
  ProcessModel m(s, 1);
  EXPECT_DOUBLE_EQ(m.at(1.0).pressure_pa, 2.0);
  EXPECT_DOUBLE_EQ(m.at(10.0).pressure_pa, 5.0);
}

TEST(PhysicsModels, InvalidSpecsAreRejected) {
  auto bad = [](TermSpec t, bool temperature = false) {
    ProcessSpec s;
    (temperature ? s.temperature : s.pressure).push_back(std::move(t));
    EXPECT_FALSE(validate(s).empty());
    EXPECT_THROW(ProcessModel(s, 1), std::invalid_argument);
  };
  bad(TableTermSpec{});
  bad(TableTermSpec{table({{2, 1}, {1, 1}})});
  bad(TableTermSpec{table({{0, 1}, {2, 1}}, Interpolation::Linear, true, 1.0)});
  bad(PulseSpec{0, 1, 1.0, 1.5});
  bad(FirstOrderSpec{table({{0, 1}}), 0.0});
  bad(SecondOrderSpec{table({{0, 1}}), 1.0, 0.0});
  bad(OrnsteinUhlenbeckSpec{0, -1, 1});
  bad(GasLawSpec{}, true);
  ProcessSpec ok;
  ok.pressure = {ConstantSpec{1}};
  EXPECT_EQ(validate(ok), "");
}

// Response terms cache modal coefficients per setpoint segment; the value must not depend on
// the order of queries (pure function of t), and must match the direct superposition.
TEST(PhysicsModels, ResponseValuesDoNotDependOnQueryOrder) {
  for (double zeta : {0.15, 1.0, 2.5}) {
    SecondOrderSpec s;
    s.setpoint = table({{0.2, 1}, {0.7, 5}, {0.7, 2}, {1.5, 2}, {2.0, -3}}, Interpolation::Linear, true, 2.4);
    s.natural_frequency_hz = 1.1;
    s.damping = zeta;
    auto fwd = pressure_model(s), rnd = pressure_model(s);
    std::vector<double> times;
    for (int i = 0; i < 400; ++i) times.push_back(i * 0.0371);
    std::vector<double> v;
    for (double t : times) v.push_back(p_at(fwd, t));
    std::vector<std::size_t> order(times.size());
    std::iota(order.begin(), order.end(), 0);
    std::uint64_t x = 12345;
    for (std::size_t i = order.size() - 1; i > 0; --i) {  // deterministic shuffle
      x = x * 6364136223846793005ULL + 1442695040888963407ULL;
      std::swap(order[i], order[(x >> 33) % (i + 1)]);
    }
    for (std::size_t i : order) EXPECT_EQ(p_at(rnd, times[i]), v[i]) << zeta << " t=" << times[i];
    // Direct superposition with the closed-form helpers.
    Table sp(s.setpoint);
    const double w = 2 * kPi * s.natural_frequency_hz;
    for (std::size_t i = 0; i < times.size(); i += 17) {
      const double t = times[i];
      double y = sp.value(t) - 2 * zeta / w * sp.slope(t - 200.0);
      sp.for_each_event_back(t, 200.0, 100000, [&](const TableEvent& ev) {
        y -= ev.step * response::second_order_free(t - ev.t_s, w, zeta) +
             ev.slope * response::second_order_integral(t - ev.t_s, w, zeta);
      });
      EXPECT_NEAR(v[i], y, 1e-9) << zeta << " t=" << t;
    }
  }
}
