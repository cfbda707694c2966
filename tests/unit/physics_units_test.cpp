// Units, quantisation helpers and the deterministic random generators.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <set>
#include <vector>

#include "physics/quantize.hpp"
#include "physics/random.hpp"
#include "physics/units.hpp"

using namespace cansim::physics;

TEST(PhysicsUnits, PressureConversionsAreExact) {
  EXPECT_EQ(to_pa(1.0, PressureUnit::psi), 6894.757293168361);
  EXPECT_EQ(to_pa(1.0, PressureUnit::bar), 1e5);
  EXPECT_EQ(to_pa(1.0, PressureUnit::mbar), 100.0);
  EXPECT_EQ(to_pa(2.5, PressureUnit::kPa), 2500.0);
  EXPECT_EQ(to_pa(1.5, PressureUnit::MPa), 1.5e6);
  EXPECT_EQ(to_pa(7.0, PressureUnit::Pa), 7.0);
  EXPECT_EQ(to_pa(1.0, PressureUnit::atm), 101325.0);
  EXPECT_EQ(to_pa(1.0, PressureUnit::at), 98066.5);
  EXPECT_EQ(from_pa(1e5, PressureUnit::bar), 1.0);
  EXPECT_EQ(from_pa(6894.757293168361, PressureUnit::psi), 1.0);
  EXPECT_NEAR(from_pa(1e5, PressureUnit::psi), 14.503773773020923, 1e-12);
  // 1 psi is derived from the pound and the inch exactly.
  EXPECT_NEAR(kPaPerPsi, 0.45359237 * 9.80665 / (0.0254 * 0.0254), 1e-9);
}

TEST(PhysicsUnits, TemperatureConversions) {
  EXPECT_EQ(to_kelvin(0.0, TemperatureUnit::degC), 273.15);
  EXPECT_EQ(to_kelvin(32.0, TemperatureUnit::degF), 273.15);
  EXPECT_DOUBLE_EQ(to_kelvin(212.0, TemperatureUnit::degF), 373.15);
  EXPECT_DOUBLE_EQ(to_kelvin(-40.0, TemperatureUnit::degF), to_kelvin(-40.0, TemperatureUnit::degC));
  EXPECT_EQ(to_kelvin(300.0, TemperatureUnit::K), 300.0);
  EXPECT_DOUBLE_EQ(from_kelvin(298.15, TemperatureUnit::degC), 25.0);
  EXPECT_DOUBLE_EQ(from_kelvin(298.15, TemperatureUnit::degF), 77.0);
  EXPECT_DOUBLE_EQ(delta_to_kelvin(9.0, TemperatureUnit::degF), 5.0);
  EXPECT_EQ(delta_to_kelvin(9.0, TemperatureUnit::degC), 9.0);
  EXPECT_DOUBLE_EQ(delta_from_kelvin(5.0, TemperatureUnit::degF), 9.0);
}

TEST(PhysicsUnits, ParsingUnitsAndQuantities) {
  EXPECT_EQ(parse_pressure_unit("bar"), PressureUnit::bar);
  EXPECT_EQ(parse_pressure_unit("mbar"), PressureUnit::mbar);
  EXPECT_EQ(parse_pressure_unit("psi"), PressureUnit::psi);
  EXPECT_EQ(parse_pressure_unit("Pa"), PressureUnit::Pa);
  EXPECT_EQ(parse_pressure_unit("kPa"), PressureUnit::kPa);
  EXPECT_EQ(parse_pressure_unit("MPa"), PressureUnit::MPa);
  EXPECT_FALSE(parse_pressure_unit("mPa"));
  EXPECT_FALSE(parse_pressure_unit("furlong"));
  EXPECT_EQ(parse_temperature_unit("degC"), TemperatureUnit::degC);
  EXPECT_EQ(parse_temperature_unit("\xC2\xB0"
                                   "C"),
            TemperatureUnit::degC);
  EXPECT_EQ(parse_temperature_unit("C"), TemperatureUnit::degC);
  EXPECT_EQ(parse_temperature_unit("degF"), TemperatureUnit::degF);
  EXPECT_EQ(parse_temperature_unit("\xC2\xB0"
                                   "F"),
            TemperatureUnit::degF);
  EXPECT_EQ(parse_temperature_unit("K"), TemperatureUnit::K);
  EXPECT_FALSE(parse_temperature_unit("k"));

  EXPECT_EQ(parse_pressure("2.5 bar"), 2.5e5);
  EXPECT_EQ(parse_pressure("1psi"), kPaPerPsi);
  EXPECT_EQ(parse_pressure("+3 kPa"), 3000.0);
  EXPECT_EQ(parse_pressure("42"), 42.0);
  EXPECT_EQ(parse_pressure("42", PressureUnit::bar), 42e5);
  EXPECT_FALSE(parse_pressure("bar"));
  EXPECT_FALSE(parse_pressure("1 parsec"));
  EXPECT_EQ(parse_temperature("25 degC"), 298.15);
  EXPECT_DOUBLE_EQ(*parse_temperature("-40 \xC2\xB0"
                                      "C"),
                   233.15);
  EXPECT_DOUBLE_EQ(*parse_temperature("212 degF"), 373.15);
  EXPECT_EQ(parse_temperature("300"), 300.0);
}

TEST(PhysicsQuantize, DecimalIntegersRoundHalfAwayAndSaturate) {
  // SMC manual: PV 1.92 (float32) with 2 decimals -> 192.
  EXPECT_EQ(to_decimal_i16(static_cast<double>(1.92f), 2).value, 192);
  EXPECT_EQ(to_decimal_i32(2.5, 0).value, 3);
  EXPECT_EQ(to_decimal_i32(-2.5, 0).value, -3);
  EXPECT_EQ(to_decimal_i32(0.0025, 3).value, 3);
  EXPECT_EQ(to_decimal_i32(-0.0025, 3).value, -3);
  // P92C worked examples: 1 bar in psi with 3 digits -> 14504; 25 degC in K, 2 digits -> 29815.
  EXPECT_EQ(to_decimal_i32(from_pa(1e5, PressureUnit::psi), 3).value, 14504);
  EXPECT_EQ(to_decimal_i32(298.15, 2).value, 29815);
  EXPECT_EQ(to_decimal_i32(1.0, 5).value, 100000);
  // Gems: 22.5 degC with 1 digit -> 225.
  EXPECT_EQ(to_decimal_i16(22.5, 1).value, 225);
  auto sat = to_decimal_i16(40.0, 3);
  EXPECT_EQ(sat.value, 32767);
  EXPECT_TRUE(sat.saturated);
  auto satn = to_decimal_i16(-40.0, 3);
  EXPECT_EQ(satn.value, -32768);
  EXPECT_TRUE(satn.saturated);
  EXPECT_FALSE(to_decimal_i16(32.767, 3).saturated);
  EXPECT_EQ(to_decimal_i32(1e12, 0).value, 2147483647);
  EXPECT_EQ(to_decimal_i24(1e12, 0).value, 8388607);
  EXPECT_TRUE(to_decimal_i32(std::nan(""), 0).saturated);
  EXPECT_EQ(from_decimal(14504, 3), 14.504);
  // Float views (IEEE single): 6.25 exactly, 0.002 rounds to 0x3B03126F.
  EXPECT_EQ(to_float32(6.25), 6.25f);
  float f = to_float32(0.002);
  std::uint32_t bits;
  std::memcpy(&bits, &f, 4);
  EXPECT_EQ(bits, 0x3B03126Fu);
  // Quantisation steps.
  EXPECT_DOUBLE_EQ(quantize_step(1.26, 0.5), 1.5);
  EXPECT_DOUBLE_EQ(quantize_step(1.24, 0.5), 1.0);
  EXPECT_EQ(quantize_step(1.24, 0.0), 1.24);
}

TEST(PhysicsRandom, SequentialAndCounterGeneratorsAreDeterministic) {
  Xoshiro256ss a(123), b(123), c(124);
  int same_c = 0;
  for (int i = 0; i < 1000; ++i) {
    const auto x = a.next();
    EXPECT_EQ(x, b.next());
    same_c += x == c.next();
  }
  EXPECT_EQ(same_c, 0);
  EXPECT_EQ(counter_hash(5, 77), counter_hash(5, 77));
  EXPECT_NE(counter_hash(5, 77), counter_hash(5, 78));
  EXPECT_NE(counter_hash(5, 77), counter_hash(6, 77));
  EXPECT_NE(derive_seed(1, 2), derive_seed(2, 1));
  EXPECT_NE(derive_seed(1, hash_string("can0/1")), derive_seed(1, hash_string("can0/2")));
  std::set<std::uint64_t> distinct;
  for (std::uint64_t k = 0; k < 1000; ++k) distinct.insert(derive_seed(99, k));
  EXPECT_EQ(distinct.size(), 1000u);
}

TEST(PhysicsQuantize, RoundHalfAwayMatchesStdRound) {
  const double edge[] = {0.0,
                         0.5,
                         -0.5,
                         1.5,
                         -1.5,
                         2.5,
                         -2.5,
                         0.49999999999999994,
                         -0.49999999999999994,
                         0x1p52 - 0.5,
                         -(0x1p52 - 0.5),
                         0x1p52,
                         0x1p52 + 1,
                         0x1p53 + 2,
                         -0x1p63,
                         1e300,
                         -1e300,
                         std::numeric_limits<double>::infinity(),
                         -std::numeric_limits<double>::infinity(),
                         std::numeric_limits<double>::denorm_min()};
  for (double x : edge) EXPECT_EQ(round_half_away(x), std::round(x)) << x;
  EXPECT_TRUE(std::isnan(round_half_away(std::nan(""))));
  Xoshiro256ss r(3);
  for (int i = 0; i < 200000; ++i) {
    const double x = std::ldexp(r.uniform(-1, 1), int(r.next() % 70) - 10);
    ASSERT_EQ(round_half_away(x), std::round(x)) << x;
    const double h = std::floor(x) + 0.5;  // ties
    ASSERT_EQ(round_half_away(h), std::round(h)) << h;
  }
}

// The ziggurat's layers: equal areas v, edges falling from r to 0.
TEST(PhysicsRandom, ZigguratLayersHaveEqualAreas) {
  const ZigguratTables& z = ziggurat_tables();
  const auto f = [](double x) { return std::exp(-0.5 * x * x); };
  const double v = z.x[0] * f(z.x[1]);
  const double base = z.x[1] * f(z.x[1]) + std::sqrt(M_PI / 2) * std::erfc(z.x[1] / std::sqrt(2.0));
  EXPECT_NEAR(base, v, 1e-12);
  for (int i = 1; i < ZigguratTables::kLayers; ++i) {
    EXPECT_GT(z.x[i], z.x[i + 1]) << i;
    EXPECT_NEAR(z.x[i] * (f(z.x[i + 1]) - f(z.x[i])), v, 1e-9) << "layer " << i;
  }
  EXPECT_EQ(z.x[ZigguratTables::kLayers], 0.0);
}

// Kolmogorov-Smirnov against the normal CDF, the tails, and the rare paths
// (wedges, tail) taken with about their expected frequency.
TEST(PhysicsRandom, CounterNormalFollowsTheNormalDistribution) {
  const int n = 400000;
  std::vector<double> z(n);
  int beyond3 = 0, beyond4 = 0, fast = 0;
  const ZigguratTables& t = ziggurat_tables();
  for (int i = 0; i < n; ++i) {
    const std::uint64_t bits = counter_hash(5, std::uint64_t(i));
    z[i] = normal_from_bits(bits);
    const double u = double(std::int64_t(bits) >> 11) * 0x1.0p-52;
    fast += std::abs(u) < t.ratio[bits & 127];
    beyond3 += std::abs(z[i]) > 3;
    beyond4 += std::abs(z[i]) > 4;
  }
  std::sort(z.begin(), z.end());
  double d = 0;
  for (int i = 0; i < n; ++i) {
    const double cdf = 0.5 * std::erfc(-z[i] / std::sqrt(2.0));
    d = std::max({d, std::abs(cdf - double(i) / n), std::abs(cdf - double(i + 1) / n)});
  }
  EXPECT_LT(d, 1.63 / std::sqrt(double(n)));  // KS at 1 %
  EXPECT_NEAR(beyond3 / double(n), 0.0026998, 0.0005);
  EXPECT_NEAR(beyond4 / double(n), 6.334e-5, 4e-5);
  double expected_fast = 0;
  for (int i = 0; i < ZigguratTables::kLayers; ++i) expected_fast += t.ratio[i] / ZigguratTables::kLayers;
  EXPECT_NEAR(expected_fast, 0.9724, 0.0001);
  EXPECT_NEAR(fast / double(n), expected_fast, 0.002);
}

TEST(PhysicsRandom, UniformAndNormalMoments) {
  Xoshiro256ss r(7);
  const int n = 200000;
  double su = 0, sn = 0, sn2 = 0, sn4 = 0, sc = 0;
  for (int i = 0; i < n; ++i) {
    const double u = r.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    su += u;
    const double z = counter_normal(11, static_cast<std::uint64_t>(i));
    sn += z;
    sn2 += z * z;
    sn4 += z * z * z * z;
    sc += uniform01(counter_hash(3, i)) < 0.25;
  }
  EXPECT_NEAR(su / n, 0.5, 0.005);
  EXPECT_NEAR(sn / n, 0.0, 0.01);
  EXPECT_NEAR(sn2 / n, 1.0, 0.01);
  EXPECT_NEAR(sn4 / n, 3.0, 0.06);  // gaussian kurtosis
  EXPECT_NEAR(sc / n, 0.25, 0.005);
}
