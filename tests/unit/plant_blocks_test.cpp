// Every plant block against its closed-form response, stepped on a fake
// clock (Plant::value at chosen simulated times): linear blocks exactly (zero-
// order hold), the gas volume against the analytic mass balance, the flow laws
// against their formulas.
#include <gtest/gtest.h>

#include <cmath>

#include "physics/plant.hpp"
#include "physics/plant_blocks.hpp"
#include "physics/process.hpp"
#include "support/plant_specs.hpp"

using namespace cansim::physics;
using cansim::test::ref;
using cansim::test::time_input;

namespace {

constexpr double kBar = 1e5;
constexpr double kPi = 3.14159265358979323846;

PlantSignal k(double v) { return PlantSignal::value(v); }

PlantInputSpec input(const std::string& name, double initial = 0.0, QuantityKind kind = QuantityKind::kNumber) {
  PlantInputSpec in;
  in.name = name;
  in.initial = initial;
  in.kind = kind;
  return in;
}

// A plant of one block `b` fed by input u.
PlantSpec one(BlockParams params, double u = 0.0) {
  PlantSpec s;
  s.name = "p";
  s.inputs.push_back(input("u", u));
  s.blocks.push_back({"b", std::move(params), std::nullopt, ""});
  return s;
}

double at(Plant& p, const char* var, double t_s) {
  const PlantVar v = p.find(var);
  EXPECT_NE(v, kNoVar) << var;
  return p.value(v, seconds_to_us(t_s));
}

}  // namespace

TEST(PlantBlocks, StatelessBlocks) {
  PlantSpec s;
  s.name = "p";
  s.inputs.push_back(input("u", 3.0));
  s.inputs.push_back(input("w", 0.5));
  s.blocks.push_back({"g", GainBlock{ref("u"), -2.5}, {}, ""});
  s.blocks.push_back({"o", OffsetBlock{ref("g"), 10.0}, {}, ""});
  s.blocks.push_back({"s", SumBlock{{ref("u"), ref("o"), k(1.0)}, {ref("w")}}, {}, ""});
  s.blocks.push_back({"sat", SaturationBlock{ref("s"), 0.0, 5.0}, {}, ""});
  s.blocks.push_back({"t", TableBlock{ref("u"), {{0.0, 0.0}, {2.0, 20.0}, {4.0, 0.0}}}, {}, ""});
  s.blocks.push_back({"tlo", TableBlock{k(-1.0), {{0.0, 7.0}, {2.0, 20.0}}}, {}, ""});
  Plant p(s, 1);
  EXPECT_DOUBLE_EQ(at(p, "g", 0), -7.5);
  EXPECT_DOUBLE_EQ(at(p, "o.out", 0), 2.5);
  EXPECT_DOUBLE_EQ(at(p, "s", 0), 3.0 + 2.5 + 1.0 - 0.5);
  EXPECT_DOUBLE_EQ(at(p, "sat", 0), 5.0);
  EXPECT_DOUBLE_EQ(at(p, "t", 0), 10.0);   // between (2, 20) and (4, 0)
  EXPECT_DOUBLE_EQ(at(p, "tlo", 0), 7.0);  // before the first point: its value
}

TEST(PlantBlocks, LagIsTheExactStepResponse) {
  LagBlock lag{ref("u"), 0.25, 2.0, 0.0};
  Plant p(one(lag, 1.5), 1);
  for (double t : {0.0, 0.001, 0.1, 0.25, 0.7, 2.0}) {
    const double expected = 3.0 * (1.0 - std::exp(-t / 0.25));
    EXPECT_NEAR(at(p, "b", t), expected, 1e-12 * 3.0) << t;
  }
}

TEST(PlantBlocks, LagWithoutInitialStartsSettled) {
  LagBlock lag{ref("u"), 0.25, 2.0};
  Plant p(one(lag, 1.5), 1);
  EXPECT_DOUBLE_EQ(at(p, "b", 0), 3.0);
  EXPECT_DOUBLE_EQ(at(p, "b", 1), 3.0);
}

TEST(PlantBlocks, SecondOrderStepResponses) {
  for (double zeta : {0.3, 1.0, 2.5}) {
    SecondOrderBlock so{ref("u"), 2.0, zeta, 1.0, 0.0};
    Plant p(one(so, 4.0), 1);
    const double w = 2 * kPi * 2.0;
    for (double t : {0.0, 0.05, 0.123, 0.5, 1.0, 3.0}) {
      const double expected = 4.0 * (1.0 - response::second_order_free(t, w, zeta));
      EXPECT_NEAR(at(p, "b", t), expected, 1e-9) << "zeta " << zeta << " t " << t;
    }
  }
}

TEST(PlantBlocks, IntegratorRampsAndDoesNotWindUp) {
  PlantSpec s;
  s.name = "p";
  // u = +2 until 1 s, then -2: a ramp to the limit 1.5 (reached at 0.75 s), then straight down.
  s.inputs.push_back(time_input("u", {RampSpec{2.0, -2.0, 1.0, 0.0}}));
  s.blocks.push_back({"i", IntegratorBlock{ref("u"), 1.0, -10.0, 1.5, 0.0}, {}, ""});
  Plant p(s, 1);
  EXPECT_NEAR(at(p, "i", 0.5), 1.0, 1e-12);
  EXPECT_NEAR(at(p, "i", 0.9), 1.5, 1e-12);
  EXPECT_NEAR(at(p, "i", 1.0), 1.5, 1e-12);
  // Anti-windup: it leaves the limit as soon as the input turns (no stored excess).
  EXPECT_NEAR(at(p, "i", 1.25), 1.0, 1e-9);
}

TEST(PlantBlocks, RateLimitRisesAndFallsAtItsRates) {
  PlantSpec s;
  s.name = "p";
  s.inputs.push_back(time_input("u", {RampSpec{0.0, 10.0, 0.0, 0.0}, RampSpec{0.0, -10.0, 2.0, 0.0}}));
  s.blocks.push_back({"r", RateLimitBlock{ref("u"), 4.0, 8.0, 0.0}, {}, ""});
  Plant p(s, 1);
  EXPECT_NEAR(at(p, "r", 1.0), 4.0, 1e-9);  // 4 per second up
  EXPECT_NEAR(at(p, "r", 2.0), 8.0, 1e-9);
  EXPECT_NEAR(at(p, "r", 2.5), 4.0, 1e-9);  // 8 per second down to 0 (from 2 s: target 0)
  EXPECT_NEAR(at(p, "r", 3.5), 0.0, 1e-9);
}

TEST(PlantBlocks, DeadTimeDelaysByWholeSteps) {
  PlantSpec s;
  s.name = "p";
  s.inputs.push_back(time_input("u", {RampSpec{1.0, 5.0, 0.100, 0.0}}));
  s.blocks.push_back({"d", DeadTimeBlock{ref("u"), 0.050}, {}, ""});
  Plant p(s, 1);
  EXPECT_EQ(at(p, "d", 0.0), 1.0);  // settled on the first input
  EXPECT_EQ(at(p, "d", 0.149), 1.0);
  EXPECT_EQ(at(p, "d", 0.150), 5.0);  // the step of 0.100 s, 50 ms later
}

TEST(PlantBlocks, HeatSourceRelaxesToAmbientPlusGainTimesPower) {
  PlantSpec s;
  s.name = "p";
  s.inputs.push_back(input("power", 200.0, QuantityKind::kPower));
  HeatSourceBlock h;
  h.time_constant_s = 30.0;
  h.gain_k_per_w = 0.05;
  h.initial_k = 293.15;
  h.power = ref("power");
  h.ambient = k(283.15);
  s.blocks.push_back({"heater", h, {}, ""});
  Plant p(s, 1);
  const double ss = 283.15 + 0.05 * 200.0;
  for (double t : {0.0, 10.0, 30.0, 100.0})
    EXPECT_NEAR(at(p, "heater.temperature", t), ss + (293.15 - ss) * std::exp(-t / 30.0), 1e-9);
}

TEST(PlantBlocks, KvGasLawMatchesTheSizingFormula) {
  const Medium air = *named_medium("air");
  const double rho_n = air.normal_density();
  EXPECT_NEAR(rho_n, 1.2922, 1e-3);
  const double c = flow::kv_gas_coefficient(0.8, air, 293.15);
  // Choked: Qn = 257 Kv p1 / sqrt(rho_n T1), p1 = 6 bar.
  const double qn_choked = 257.0 * 0.8 * 6.0 / std::sqrt(rho_n * 293.15);  // m3/h
  flow::Flow f = flow::kv_gas(6 * kBar, 1 * kBar, c, 1000);
  EXPECT_NEAR(f.m, qn_choked * rho_n / 3600.0, 1e-12);
  EXPECT_NEAR(f.d1, f.m / (6 * kBar), 1e-18);
  EXPECT_EQ(f.d2, 0.0);
  // Subcritical: Qn = 514 Kv sqrt(dp p2 / (rho_n T1)), p1 = 3, p2 = 2 bar.
  const double qn_sub = 514.0 * 0.8 * std::sqrt(1.0 * 2.0 / (rho_n * 293.15));
  f = flow::kv_gas(3 * kBar, 2 * kBar, c, 1000);
  EXPECT_NEAR(f.m, qn_sub * rho_n / 3600.0, 1e-12);
  // Continuous at the critical ratio, and in the linear region.
  EXPECT_NEAR(flow::kv_gas(4 * kBar, 2 * kBar, c, 1000).m, flow::kv_gas(4 * kBar, 2 * kBar - 1e-3, c, 1000).m, 1e-9);
  const flow::Flow edge = flow::kv_gas(2 * kBar + 1000, 2 * kBar, c, 1000);
  EXPECT_NEAR(flow::kv_gas(2 * kBar + 1000 - 1e-6, 2 * kBar, c, 1000).m, edge.m, 1e-9);
  EXPECT_NEAR(flow::kv_gas(2 * kBar + 500, 2 * kBar, c, 1000).m, edge.m / 2, 1e-9);
}

TEST(PlantBlocks, LiquidAndOrificeLaws) {
  // Liquid Kv: Q = Kv sqrt(dp / SG) [m3/h, bar].
  const flow::Flow w = flow::kv_liquid(3 * kBar, 1 * kBar, 2.0, 998.2, 1000);
  EXPECT_NEAR(w.m, 2.0 * std::sqrt(2.0 / 0.9982) * 998.2 / 3600.0, 1e-12);
  // Liquid orifice: m = Cd A sqrt(2 rho dp).
  EXPECT_NEAR(flow::orifice_liquid(2 * kBar, 1 * kBar, 1e-5, 1000, 1000).m, 1e-5 * std::sqrt(2 * 1000 * 1e5), 1e-12);
  // Gas orifice, choked: m = Cd A p1 sqrt(g / (R T) (2 / (g + 1))^((g + 1) / (g - 1))).
  const Medium air = *named_medium("air");
  const double g = 1.4, rt = 287.05 * 293.15;
  const double choked = 1e-6 * 6 * kBar * std::sqrt(g / rt * std::pow(2 / (g + 1), (g + 1) / (g - 1)));
  EXPECT_NEAR(flow::orifice_gas(6 * kBar, 1 * kBar, 1e-6, air, 293.15, 1000).m, choked, 1e-12);
  // Subsonic tends to the choked value at the critical ratio.
  const double critical = std::pow(2 / (g + 1), g / (g - 1));
  EXPECT_NEAR(flow::orifice_gas(6 * kBar, critical * 6 * kBar * 1.000001, 1e-6, air, 293.15, 1000).m, choked,
              choked * 1e-4);
}

// A 2 l vessel fed with a constant mass flow, vented through a choked Kv
// valve to the ambient: C dp/dt = q - c p (c: the choked coefficient), a
// first-order response with tau = C / c towards q / c, C = V / (R T).
TEST(PlantBlocks, VesselWithChokedVentIsAFirstOrderSystem) {
  const Medium air = *named_medium("air");
  PlantSpec s;
  s.name = "rig";
  s.inputs.push_back(input("feed", 5e-3, QuantityKind::kMassFlow));
  s.inputs.push_back(input("opening", 0.5, QuantityKind::kFraction));
  GasVolumeBlock vessel;
  vessel.volume_m3 = 2e-3;
  vessel.initial_pressure_pa = 3 * kBar;
  vessel.inflow = {ref("feed")};
  vessel.outflow = {ref("vent")};
  s.blocks.push_back({"vessel", vessel, {}, ""});
  ValveBlock vent;
  vent.kv = 0.4;
  vent.upstream = ref("vessel.pressure");
  vent.opening = ref("opening");
  s.blocks.push_back({"vent", vent, {}, ""});
  Plant p(s, 1);
  const double cap = 2e-3 / (air.r_specific * kRoomTemperatureK);
  const double c = flow::kv_gas_coefficient(0.4 * 0.5, air, kRoomTemperatureK);
  const double tau = cap / c, final = 5e-3 / c;
  ASSERT_GT(final, 2.1 * kBar);  // stays choked
  for (double t : {0.0, 0.5, 1.0, 2.0, 5.0, 20.0}) {
    const double expected = final + (3 * kBar - final) * std::exp(-t / tau);
    EXPECT_NEAR(at(p, "pressure", t), expected, 1e-6 * kBar) << t;  // exponential Euler: exact but for rounding
  }
  EXPECT_NEAR(at(p, "vent.flow", 60.0), 5e-3, 1e-9);
}

TEST(PlantBlocks, ClosedVolumeFollowsItsTemperature) {
  PlantSpec s;
  s.name = "p";
  s.inputs.push_back(input("heat", 100.0, QuantityKind::kPower));
  HeatSourceBlock h;
  h.time_constant_s = 10.0;
  h.gain_k_per_w = 0.5;
  h.initial_k = 293.15;
  h.power = ref("heat");
  h.ambient = k(293.15);
  s.blocks.push_back({"wall", h, {}, ""});
  GasVolumeBlock g;
  g.volume_m3 = 1e-3;
  g.initial_pressure_pa = 2 * kBar;
  g.temperature = ref("wall.temperature");
  s.blocks.push_back({"gas", g, {}, ""});
  Plant p(s, 1);
  for (double t : {0.0, 5.0, 30.0}) {
    const double temp = at(p, "wall.temperature", t);
    EXPECT_NEAR(at(p, "gas.pressure", t), 2 * kBar * temp / 293.15, 1e-6) << t;  // isochoric: p / T constant
  }
}

TEST(PlantBlocks, PumpFlowAndCurveWithAffinityLaws) {
  PlantSpec s;
  s.name = "p";
  s.inputs.push_back(input("speed", 0.5, QuantityKind::kFraction));
  s.inputs.push_back(input("outlet", 3 * kBar, QuantityKind::kPressure));
  PumpBlock plain;
  plain.nominal_flow_kgs = 0.01;
  plain.speed = ref("speed");
  s.blocks.push_back({"plain", plain, {}, ""});
  PumpBlock curved;
  curved.curve = {{0.0, 0.02}, {4 * kBar, 0.0}};  // 0.02 kg/s free flow, shut-off at 4 bar
  curved.speed = ref("speed");
  curved.outlet = ref("outlet");
  curved.inlet = k(1 * kBar);
  s.blocks.push_back({"curved", curved, {}, ""});
  Plant p(s, 1);
  EXPECT_DOUBLE_EQ(at(p, "plain", 0), 0.005);
  // dp 2 bar at half speed is 8 bar at full speed: beyond shut-off, no flow;
  const PlantVar outlet = *p.find_input("outlet");
  EXPECT_DOUBLE_EQ(at(p, "curved", 0), 0.0);
  p.set_input(outlet, 1.5 * kBar, 0);  // dp 0.5 bar at half speed = 2 bar at full speed: half the free flow, halved
  EXPECT_NEAR(at(p, "curved", 0.001), 0.5 * 0.01, 1e-12);
}

TEST(PlantBlocks, LineDelaysAFlowAndBlockedClosesIt) {
  PlantSpec s;
  s.name = "p";
  s.inputs.push_back(time_input("q", {RampSpec{0.0, 2e-3, 0.010, 0.0}}));
  s.blocks.push_back({"pipe", LineBlock{ref("q"), 0.020}, {}, ""});
  PlantFaultSpec f;
  f.fault.kind = FaultKind::Blocked;
  f.fault.timing.at_us = 100'000;
  f.fault.timing.duration_us = 50'000;
  f.target = "pipe";
  s.faults.push_back(f);
  Plant p(s, 1);
  EXPECT_EQ(at(p, "pipe", 0.029), 0.0);  // an empty line delivers nothing for 20 ms
  EXPECT_EQ(at(p, "pipe", 0.030), 2e-3);
  EXPECT_EQ(at(p, "pipe", 0.120), 0.0);  // blocked
  EXPECT_EQ(at(p, "pipe", 0.150), 2e-3);
}
