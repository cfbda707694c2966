// The flow laws of the plant engine's restrictions (physics/plant.hpp:
// valves, orifices, leaks), with the partial derivatives a gas volume uses to
// integrate its mass balance implicitly. Exposed for tests.
//
// Every law gives the mass flow from side 1 to side 2 for p1 >= p2 and is
// linear in dp below `linear` Pa (continuous at it), so its derivative stays
// finite where the square-root laws have none.
#pragma once

#include <cmath>

#include "physics/plant_units.hpp"

namespace cansim::physics::flow {

struct Flow {
  double m = 0;   // kg/s
  double d1 = 0;  // dm / dp1, kg/s per Pa
  double d2 = 0;  // dm / dp2
};

// Gas through a Kv restriction (VDI/VDE 2173): choked for p2 <= p1 / 2, m =
// c p1; subcritical m = 2 c sqrt((p1 - p2) p2) (continuous at p1 / 2).
Flow kv_gas(double p1, double p2, double c, double linear);
// kv_gas's c (kg/s per Pa of p1) for Kv (m3/h), the gas and the upstream
// temperature: Qn = 257 Kv p1 / sqrt(rho_n T1) [m3/h, bar, kg/m3, K].
double kv_gas_coefficient(double kv, const Medium& gas, double t1_k);
// Liquid through a Kv restriction: Q = Kv sqrt(dp / SG) [m3/h, bar], m =
// c sqrt(dp) with c = Kv sqrt(0.01 rho) / 3600 [dp in Pa].
Flow kv_liquid(double p1, double p2, double kv, double density, double linear);
// Gas through an orifice of effective area k = Cd A (isentropic nozzle):
// choked below the critical ratio (2 / (g + 1))^(g / (g - 1)).
Flow orifice_gas(double p1, double p2, double k, const Medium& gas, double t1_k, double linear);
// Liquid through an orifice (Bernoulli): m = k sqrt(2 rho dp).
Flow orifice_liquid(double p1, double p2, double k, double density, double linear);

// (e^z - 1) / z, 1 at z = 0: the exponential Euler factor.
inline double phi1(double z) { return std::abs(z) < 1e-9 ? 1.0 + 0.5 * z : std::expm1(z) / z; }

}  // namespace cansim::physics::flow
