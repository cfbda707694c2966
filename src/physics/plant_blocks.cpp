#include "physics/plant_blocks.hpp"

#include <algorithm>

namespace cansim::physics::flow {

namespace {
constexpr double kPaPerBar = 1e5;
constexpr double kSecondsPerHour = 3600.0;

// A law m = f(dp) made linear below `linear`: the value and slope there.
template <class Law>
Flow linearised(double dp, double linear, Law&& law) {
  const Flow at = law(linear);
  const double slope = at.m / linear;
  return {slope * dp, slope, -slope};
}
}  // namespace

double kv_gas_coefficient(double kv, const Medium& gas, double t1_k) {
  const double rho_n = gas.normal_density();
  // Qn [m3/h] = 257 Kv p1[bar] / sqrt(rho_n T1); m = Qn rho_n / 3600.
  return 257.0 * kv * rho_n / (kSecondsPerHour * kPaPerBar * std::sqrt(rho_n * t1_k));
}

Flow kv_gas(double p1, double p2, double c, double linear) {
  if (p1 <= 0 || c <= 0) return {};
  p2 = std::max(p2, 0.0);
  if (p2 <= 0.5 * p1) return {c * p1, c, 0.0};  // choked: no dependence on p2
  const double dp = p1 - p2;
  auto law = [&](double d) {
    const double q = 2.0 * c * std::sqrt(d * p2);
    return Flow{q, q / (2.0 * d), q * (p1 - 2.0 * p2) / (2.0 * d * p2)};
  };
  if (dp < linear) return linearised(dp, linear, law);
  return law(dp);
}

Flow kv_liquid(double p1, double p2, double kv, double density, double linear) {
  const double dp = p1 - p2;
  if (kv <= 0 || dp <= 0) return {};
  const double c = kv * std::sqrt(0.01 * density) / kSecondsPerHour;
  auto law = [&](double d) {
    const double q = c * std::sqrt(d);
    return Flow{q, q / (2.0 * d), -q / (2.0 * d)};
  };
  if (dp < linear) return linearised(dp, linear, law);
  return law(dp);
}

Flow orifice_gas(double p1, double p2, double k, const Medium& gas, double t1_k, double linear) {
  if (p1 <= 0 || k <= 0) return {};
  p2 = std::max(p2, 0.0);
  const double g = gas.gamma;
  const double rt = gas.r_specific * t1_k;
  const double critical = std::pow(2.0 / (g + 1.0), g / (g - 1.0));
  const double pr = p2 / p1;
  if (pr <= critical) {
    const double psi = std::sqrt(g / rt * std::pow(2.0 / (g + 1.0), (g + 1.0) / (g - 1.0)));
    return {k * p1 * psi, k * psi, 0.0};
  }
  const double a = std::sqrt(2.0 * g / ((g - 1.0) * rt));
  auto law = [&](double d) {
    const double r = std::max((p1 - d) / p1, critical);  // the pressure ratio at this dp
    const double f = std::pow(r, 2.0 / g) - std::pow(r, (g + 1.0) / g);
    const double df = (2.0 / g) * std::pow(r, 2.0 / g - 1.0) - ((g + 1.0) / g) * std::pow(r, 1.0 / g);
    const double sf = std::sqrt(std::max(f, 1e-300));
    const double m = k * a * p1 * sf;
    // m = k a p1 sqrt(f(p2 / p1)): dm/dp2 = k a f' / (2 sqrt f), dm/dp1 = k a (sqrt f - r f' / (2 sqrt f)).
    return Flow{m, k * a * (sf - r * df / (2.0 * sf)), k * a * df / (2.0 * sf)};
  };
  const double dp = p1 - p2;
  if (dp < linear) return linearised(dp, linear, law);
  return law(dp);
}

Flow orifice_liquid(double p1, double p2, double k, double density, double linear) {
  const double dp = p1 - p2;
  if (k <= 0 || dp <= 0) return {};
  auto law = [&](double d) {
    const double q = k * std::sqrt(2.0 * density * d);
    return Flow{q, q / (2.0 * d), -q / (2.0 * d)};
  };
  if (dp < linear) return linearised(dp, linear, law);
  return law(dp);
}

}  // namespace cansim::physics::flow
