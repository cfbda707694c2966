#include "physics/random.hpp"

#include <cmath>

namespace cansim::physics {

namespace {

// The tail starts at r; every layer, and the base with its tail, has area v
// under f(x) = exp(-x^2 / 2). r solves the recurrence below ending at x = 0.
constexpr double kR = 3.4426198558966514;
constexpr double kV = 0.009912563035336481;

double density(double x) { return std::exp(-0.5 * x * x); }

ZigguratTables make_tables() {
  ZigguratTables z{};
  constexpr int n = ZigguratTables::kLayers;
  z.x[0] = kV / density(kR);
  z.x[1] = kR;
  for (int i = 1; i < n - 1; ++i) z.x[i + 1] = std::sqrt(-2.0 * std::log(density(z.x[i]) + kV / z.x[i]));
  z.x[n] = 0.0;
  for (int i = 0; i < n; ++i) z.ratio[i] = z.x[i + 1] / z.x[i];
  return z;
}

double uniform_open(std::uint64_t bits) { return (double(bits >> 11) + 1.0) * 0x1.0p-53; }  // (0, 1]

std::uint64_t next_bits(std::uint64_t bits) { return mix64(bits + 0x9E3779B97F4A7C15ULL); }

// Marsaglia (1964): beyond r, x = r + e1 / r accepted when 2 e2 >= (e1 / r)^2.
double tail(bool negative, std::uint64_t& bits) {
  for (;;) {
    bits = next_bits(bits);
    const double x = -std::log(uniform_open(bits)) / kR;
    bits = next_bits(bits);
    const double y = -std::log(uniform_open(bits));
    if (y + y >= x * x) return negative ? -(kR + x) : kR + x;
  }
}

}  // namespace

const ZigguratTables& ziggurat_tables() {
  static const ZigguratTables tables = make_tables();
  return tables;
}

double normal_from_bits_slow(std::uint64_t bits) {
  const ZigguratTables& z = ziggurat_tables();
  for (;;) {
    const unsigned layer = unsigned(bits & (ZigguratTables::kLayers - 1));
    const double u = double(std::int64_t(bits) >> 11) * 0x1.0p-52;
    if (std::abs(u) < z.ratio[layer]) return u * z.x[layer];
    if (layer == 0) return tail(u < 0, bits);
    // The wedge between the layer's inner and outer edge: under the curve
    // with probability (f(x) - f(x[i])) / (f(x[i+1]) - f(x[i])).
    const double x = u * z.x[layer];
    bits = next_bits(bits);
    const double f_outer = density(z.x[layer]), f_inner = density(z.x[layer + 1]);
    if (f_outer + uniform01(bits) * (f_inner - f_outer) < density(x)) return x;
    bits = next_bits(bits);
  }
}

}  // namespace cansim::physics
