// The plant engine as a whole (physics/plant.hpp): names and wiring, refused
// graphs and parameters, inputs (push, timeout, override, time terms, another
// plant), faults, history and determinism, NaN containment, laziness.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "physics/plant.hpp"
#include "physics/process.hpp"
#include "support/plant_specs.hpp"
#include "physics/sensor.hpp"
#include "support/counting_new.hpp"

using namespace cansim::physics;
using cansim::test::ref;
using cansim::test::time_input;

namespace {

constexpr double kBar = 1e5;

PlantInputSpec input(const std::string& name, double initial = 0.0) {
  PlantInputSpec in;
  in.name = name;
  in.initial = initial;
  in.origin = "f.yaml:3:5: plants.p.inputs." + name;
  return in;
}

PlantInputSpec plant_input(const std::string& name, const std::string& plant_ref) {
  PlantInputSpec in = input(name);
  in.source = PlantInputSpec::Source::kPlant;
  in.plant_ref = plant_ref;
  return in;
}

BlockSpec block(const std::string& name, BlockParams p) {
  return {name, std::move(p), std::nullopt, "f.yaml:9:7: plants.p.blocks." + name};
}

// A vessel with a feed input and a vent valve driven by input "valve".
PlantSpec rig(const std::string& name = "rig") {
  PlantSpec s;
  s.name = name;
  s.origin = "f.yaml:2:3: plants." + name;
  s.inputs.push_back(input("feed", 4e-3));
  PlantInputSpec valve = input("valve", 0.5);
  valve.kind = QuantityKind::kFraction;
  s.inputs.push_back(valve);
  GasVolumeBlock v;
  v.volume_m3 = 2e-3;
  v.initial_pressure_pa = 4 * kBar;
  v.inflow = {ref("feed")};
  v.outflow = {ref("vent")};
  s.blocks.push_back(block("vessel", v));
  ValveBlock vent;
  vent.kv = 0.3;
  vent.upstream = ref("vessel.pressure");
  vent.opening = ref("valve");
  s.blocks.push_back(block("vent", vent));
  return s;
}

// A pressure channel reading vessel.pressure, and a 0..10 bar pressure sensor.
ProcessSpec reads_vessel() {
  ProcessSpec spec;
  spec.pressure = {PlantTermSpec{"vessel.pressure", ""}};
  spec.temperature = {ConstantSpec{293.15}};
  return spec;
}

SensorSpec pressure_sensor() {
  SensorSpec sensor;
  sensor.pressure.range_max = 10 * kBar;
  sensor.temperature.enabled = false;
  return sensor;
}

std::string error_of(const PlantSpec& s) {
  try {
    Plant p(s, 1);
  } catch (const PlantError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Plant, VariablesByName) {
  Plant p(rig(), 1);
  EXPECT_EQ(p.find("vessel.pressure"), p.find("pressure"));
  EXPECT_EQ(p.find("vessel"), p.find("vessel.pressure"));  // a block: its first output
  EXPECT_EQ(p.find("vent"), p.find("vent.flow"));
  EXPECT_NE(p.find("feed"), kNoVar);
  EXPECT_EQ(p.variables()[p.find("valve")].kind, QuantityKind::kFraction);
  EXPECT_EQ(p.variables()[p.find("vessel.mass")].kind, QuantityKind::kMass);
  std::string why;
  EXPECT_EQ(p.find("vessel.volume", &why), kNoVar);
  EXPECT_NE(why.find("no variable 'vessel.volume'"), std::string::npos) << why;
  EXPECT_NE(why.find("vessel.pressure"), std::string::npos) << why;  // says what there is
}

TEST(Plant, UnknownNamesAndAmbiguousOutputsNameTheirPlace) {
  PlantSpec s = rig();
  std::get<ValveBlock>(s.blocks[1].params).opening =
      PlantSignal{"valv", 0, "f.yaml:12:20: plants.rig.blocks.vent.opening"};
  std::string e = error_of(s);
  EXPECT_EQ(e.rfind("f.yaml:12:20: plants.rig.blocks.vent.opening: unknown name 'valv'", 0), 0u) << e;

  PlantSpec two = rig();
  two.blocks.push_back(block("tank2", std::get<GasVolumeBlock>(two.blocks[0].params)));
  std::get<ValveBlock>(two.blocks[1].params).upstream = ref("pressure");
  e = error_of(two);
  EXPECT_NE(e.find("'pressure' is ambiguous: vessel.pressure, tank2.pressure"), std::string::npos) << e;
}

TEST(Plant, AnAlgebraicLoopIsRefusedNamingTheCycle) {
  PlantSpec s;
  s.name = "loop";
  s.blocks.push_back(block("a", GainBlock{ref("c"), 0.5}));
  s.blocks.push_back(block("b", OffsetBlock{ref("a"), 1.0}));
  s.blocks.push_back(block("c", SumBlock{{ref("b")}, {}}));
  const std::string e = error_of(s);
  EXPECT_NE(e.find("algebraic loop a -> c -> b -> a"), std::string::npos) << e;
  EXPECT_EQ(e.rfind("f.yaml:9:7: plants.p.blocks.a: ", 0), 0u) << e;
  // The same loop through a lag holds state: accepted, and it settles at the fixed point.
  s.blocks[2].params = LagBlock{ref("b"), 0.1, 1.0, 0.0};
  Plant p(s, 1);
  EXPECT_NEAR(p.value(p.find("c"), 5'000'000), 2.0, 1e-9);  // c = 0.5 c + 1
}

TEST(Plant, ImpossibleParametersAreRefused) {
  PlantSpec s = rig();
  std::get<GasVolumeBlock>(s.blocks[0].params).volume_m3 = -1e-3;
  EXPECT_NE(error_of(s).find("plants.p.blocks.vessel: expected a volume > 0"), std::string::npos) << error_of(s);
  PlantSpec lag;
  lag.name = "p";
  lag.inputs.push_back(input("u"));
  lag.blocks.push_back(block("l", LagBlock{ref("u"), 0.0}));
  EXPECT_NE(error_of(lag).find("expected a time constant > 0"), std::string::npos);
  lag.blocks[0].params = DeadTimeBlock{ref("u"), 0.0001};
  EXPECT_NE(error_of(lag).find("expected a delay of at least one step"), std::string::npos);
  lag.blocks[0].params = SecondOrderBlock{ref("u"), 1.0, 0.0};
  EXPECT_NE(error_of(lag).find("expected a damping ratio > 0"), std::string::npos);
  PlantSpec liquid = rig();
  liquid.medium = *named_medium("water");
  EXPECT_NE(error_of(liquid).find("a gas_volume needs a gas medium"), std::string::npos);
  PlantSpec step = rig();
  step.step_us = 0;
  EXPECT_NE(error_of(step).find("expected a step"), std::string::npos);
}

TEST(Plant, NothingIsComputedUntilSomeoneReads) {
  Plant p(rig(), 1);
  EXPECT_EQ(p.steps(), 0u);
  p.value(p.find("pressure"), 10'000);
  EXPECT_EQ(p.steps(), 11u);  // steps 0..10
  p.value(p.find("pressure"), 10'999);
  EXPECT_EQ(p.steps(), 11u);  // still step 10
}

TEST(Plant, AnInputActsFromTheStepAfterItArrived) {
  Plant p(rig(), 1);
  const PlantVar valve = p.find("valve");
  const std::size_t in = *p.find_input("valve");
  p.set_input(in, 0.8, 2'500);  // between steps 2 and 3
  EXPECT_EQ(p.value(valve, 2'999), 0.5);
  EXPECT_EQ(p.value(valve, 3'000), 0.8);
  EXPECT_EQ(p.input_state(in).updated, 2'500);
  p.set_input(in, std::numeric_limits<double>::quiet_NaN(), 4'000);  // refused, counted
  EXPECT_EQ(p.value(valve, 6'000), 0.8);
  EXPECT_EQ(p.input_state(in).refused, 1u);
}

TEST(Plant, ATimeoutHoldsOrGoesToItsValue) {
  PlantSpec s = rig();
  s.inputs[1].timeout_us = 100'000;
  s.inputs[1].on_timeout = 0.0;      // a lost command closes the valve
  s.inputs[0].timeout_us = 100'000;  // feed: hold
  Plant p(s, 1);
  const std::size_t valve = 1, feed = 0;
  p.set_input(valve, 0.7, 50'000);
  p.set_input(feed, 3e-3, 50'000);
  EXPECT_EQ(p.value(p.find("valve"), 149'000), 0.7);
  EXPECT_EQ(p.value(p.find("valve"), 150'000), 0.0);
  EXPECT_TRUE(p.input_state(valve).timed_out);
  EXPECT_EQ(p.value(p.find("feed"), 150'000), 3e-3);  // held
  EXPECT_TRUE(p.input_state(feed).timed_out);
  p.set_input(valve, 0.6, 200'000);  // comes back
  EXPECT_EQ(p.value(p.find("valve"), 201'000), 0.6);
  EXPECT_FALSE(p.input_state(valve).timed_out);
}

TEST(Plant, OverrideWinsUntilCleared) {
  Plant p(rig(), 1);
  p.override_input(1, 0.4, 1'000);
  p.set_input(1, 0.9, 2'000);
  EXPECT_EQ(p.value(p.find("valve"), 10'000), 0.4);
  EXPECT_TRUE(p.input_state(1).overridden);
  EXPECT_EQ(p.input_state(1).source_value, 0.9);
  p.clear_override(1, 10'000);
  EXPECT_EQ(p.value(p.find("valve"), 11'000), 0.9);
}

TEST(Plant, TimeInputsAreTodaysTerms) {
  PlantSpec s;
  s.name = "p";
  s.inputs.push_back(time_input("dist", {ConstantSpec{2.0}, SineSpec{0.5, 10.0, 0.0}}));
  s.blocks.push_back(block("g", GainBlock{ref("dist"), 1.0}));
  Plant p(s, 1);
  for (TimeUs t : {0, 12'000, 25'000, 1'000'000})
    EXPECT_NEAR(p.value(p.find("g"), t), 2.0 + 0.5 * std::sin(2 * 3.14159265358979 * 10.0 * us_to_seconds(t)), 1e-9);
}

TEST(Plant, FaultsOnBlocksAndInputs) {
  PlantSpec s = rig();
  Plant p(s, 1);
  const PlantVar pressure = p.find("pressure"), flow = p.find("vent.flow"), valve = p.find("valve");
  const double before = p.value(pressure, 1'000'000);
  // blocked: the vent passes nothing, the vessel fills at the feed rate.
  PlantFaultSpec blocked;
  blocked.fault.kind = FaultKind::Blocked;
  blocked.fault.timing.duration_us = 500'000;
  blocked.target = "vent";
  const FaultHandle h = p.arm_fault(blocked, 1'000'000);
  EXPECT_EQ(p.value(flow, 1'200'000), 0.0);
  const double at_1200 = p.value(pressure, 1'200'000);
  const double rise = p.value(pressure, 1'400'000) - at_1200;
  const double cap = 2e-3 / (287.05 * kRoomTemperatureK);
  EXPECT_NEAR(rise, 4e-3 * 0.2 / cap, 1.0);  // dp = q dt / C
  EXPECT_GT(p.value(flow, 1'600'000), 0.0);
  EXPECT_EQ(p.armed_faults(1'600'000).size(), 0u);
  EXPECT_GT(before, 0);
  (void)h;
  // valve_stuck on the input: frozen at its value at the onset, whatever arrives.
  PlantFaultSpec stuck;
  stuck.fault.kind = FaultKind::ValveStuck;
  stuck.target = "valve";
  const FaultHandle hs = p.arm_fault(stuck, 2'000'000);
  p.set_input(1, 0.9, 2'100'000);
  EXPECT_EQ(p.value(valve, 2'200'000), 0.5);
  EXPECT_TRUE(p.input_state(1).stuck);
  p.cancel_fault(hs, 2'300'000);
  EXPECT_EQ(p.value(valve, 2'301'000), 0.9);
  // input_lost: what arrives is dropped; with a timeout, the timeout shows.
  PlantFaultSpec lost;
  lost.fault.kind = FaultKind::InputLost;
  lost.target = "valve";
  p.arm_fault(lost, 3'000'000);
  p.set_input(1, 0.1, 3'100'000);
  EXPECT_EQ(p.value(valve, 3'200'000), 0.9);
  EXPECT_TRUE(p.input_state(1).lost);
  // leak: the vessel settles lower; a kind that does not fit its target is refused.
  PlantFaultSpec leak;
  leak.fault.kind = FaultKind::Leak;
  leak.fault.leak_kv = 0.05;
  leak.target = "vessel";
  const double settled = p.value(pressure, 30'000'000);
  p.arm_fault(leak, 30'000'000);
  EXPECT_LT(p.value(pressure, 60'000'000), settled - 0.2 * kBar);
  leak.target = "vent";
  EXPECT_THROW(p.arm_fault(leak, 60'000'000), PlantError);
  blocked.target = "vessel";
  EXPECT_THROW(p.arm_fault(blocked, 60'000'000), PlantError);
  lost.target = "nowhere";
  EXPECT_THROW(p.arm_fault(lost, 60'000'000), PlantError);
}

// Each plant fault kind on its own, scheduled as node faults are (start
// after arming, a duration), on the plant's own clock.
TEST(PlantFaults, ALeakIsAnExtraOutflowFromItsStartToItsEnd) {
  PlantSpec s = rig();
  s.inputs[0].initial = 0.0;  // no feed
  s.inputs[1].initial = 0.0;  // vent closed: a closed vessel
  Plant p(s, 1);
  const PlantVar pressure = p.find("pressure");
  PlantFaultSpec leak;
  leak.fault.kind = FaultKind::Leak;
  leak.fault.leak_flow_kgs = 1e-3;
  leak.fault.timing.after_us = 100'000;
  leak.fault.timing.duration_us = 200'000;
  leak.target = "vessel";
  p.arm_fault(leak, 0);
  EXPECT_DOUBLE_EQ(p.value(pressure, 99'000), 4 * kBar);                      // not yet
  const double cap = 2e-3 / (287.05 * kRoomTemperatureK);                     // kg/Pa (isothermal ideal gas)
  EXPECT_NEAR(p.value(pressure, 200'000), 4 * kBar - 1e-3 * 0.1 / cap, 2.0);  // dp = -q dt / C
  const double after = p.value(pressure, 300'000);
  EXPECT_NEAR(after, 4 * kBar - 1e-3 * 0.2 / cap, 2.0);
  EXPECT_EQ(p.value(pressure, 900'000), after);  // over: the vessel holds again
  EXPECT_TRUE(p.armed_faults(900'000).empty());
}

TEST(PlantFaults, BlockedClosesTheValveForItsDuration) {
  Plant p(rig(), 1);
  const PlantVar flow = p.find("vent.flow");
  PlantFaultSpec blocked;
  blocked.fault.kind = FaultKind::Blocked;
  blocked.fault.timing.after_us = 50'000;
  blocked.fault.timing.duration_us = 100'000;
  blocked.target = "vent";
  p.arm_fault(blocked, 0);
  EXPECT_GT(p.value(flow, 49'000), 0.0);
  EXPECT_EQ(p.value(flow, 50'000), 0.0);
  EXPECT_EQ(p.value(flow, 149'000), 0.0);
  EXPECT_GT(p.value(flow, 150'000), 0.0);
}

TEST(PlantFaults, AStuckValveHoldsItsInputWhateverArrives) {
  Plant p(rig(), 1);
  const PlantVar valve = p.find("valve");
  PlantFaultSpec stuck;
  stuck.fault.kind = FaultKind::ValveStuck;
  stuck.target = "valve";
  stuck.fault.timing.duration_us = 200'000;
  p.set_input(1, 0.3, 10'000);
  p.arm_fault(stuck, 100'000);
  p.set_input(1, 0.9, 150'000);
  EXPECT_EQ(p.value(valve, 299'000), 0.3);
  EXPECT_TRUE(p.input_state(1).stuck);
  EXPECT_EQ(p.value(valve, 301'000), 0.9);  // released: what arrived meanwhile
  EXPECT_FALSE(p.input_state(1).stuck);
}

TEST(PlantFaults, ALostInputShowsItsTimeoutBehaviour) {
  PlantSpec s = rig();
  s.inputs[1].timeout_us = 100'000;
  s.inputs[1].on_timeout = 0.0;  // no command: the valve closes
  Plant p(s, 1);
  const PlantVar valve = p.find("valve");
  PlantFaultSpec lost;
  lost.fault.kind = FaultKind::InputLost;
  lost.target = "valve";
  lost.fault.timing.at_us = 1'000'000;
  lost.fault.timing.duration_us = 500'000;
  p.arm_fault(lost, 0);
  // The controller keeps sending 70 % every 10 ms; from 1 s nothing reaches the plant.
  for (TimeUs t = 0; t <= 2'000'000; t += 10'000) {
    p.set_input(1, 0.7, t);
    if (t == 1'080'000) {
      EXPECT_EQ(p.value(valve, t), 0.7) << "held until the timeout";
    }
    if (t == 1'200'000) {
      EXPECT_EQ(p.value(valve, t), 0.0) << "the timeout shows";
      EXPECT_TRUE(p.input_state(1).lost);
      EXPECT_TRUE(p.input_state(1).timed_out);
    }
  }
  EXPECT_EQ(p.value(valve, 2'000'000), 0.7);  // the fault is over: the commands arrive again
  EXPECT_FALSE(p.input_state(1).lost);
}

TEST(Plant, TheSameWhoeverReadsItAndHowOften) {
  Plant a(rig(), 7), b(rig(), 7);
  const PlantVar pa = a.find("pressure"), pb = b.find("pressure");
  a.set_input(1, 0.2, 300'000);
  b.set_input(1, 0.2, 300'000);
  for (TimeUs t = 0; t <= 2'000'000; t += 1'000) a.value(pa, t);  // read every step
  EXPECT_EQ(a.value(pa, 2'000'000), b.value(pb, 2'000'000));      // b read once
  // History: a watched variable read in the past after the plant moved on.
  Plant c(rig(), 7);
  const PlantVar pc = c.find("pressure");
  c.watch(pc, 100'000);
  c.set_input(1, 0.2, 300'000);
  const double at_1s = Plant(rig(), 7).value(pc, 1'000'000);  // another plant, not yet at 0.2: differs
  Plant d(rig(), 7);
  d.set_input(1, 0.2, 300'000);
  const double expected = d.value(pc, 1'000'000);
  c.value(pc, 1'050'000);
  EXPECT_EQ(c.value(pc, 1'000'000), expected);
  EXPECT_NE(c.value(pc, 1'000'000), at_1s);
  EXPECT_NE(c.value(pc, 1'000'000), c.value(pc, 1'050'000));
}

TEST(Plant, ANonFiniteValueNeverLeavesABlock) {
  PlantSpec s;
  s.name = "p";
  s.inputs.push_back(input("u", 1.0));
  s.blocks.push_back(block("big", GainBlock{ref("u"), 1e300}));
  s.blocks.push_back(block("bigger", GainBlock{ref("big"), 1e300}));  // 1e600: infinity
  Plant p(s, 1);
  struct Seen {
    std::string block;
    std::uint64_t count = 0;
  } seen;
  p.set_non_finite_hook(
      [](void* c, const std::string&, const std::string& block, std::uint64_t n, TimeUs) {
        static_cast<Seen*>(c)->block = block;
        static_cast<Seen*>(c)->count = n;
      },
      &seen);
  const double v = p.value(p.find("bigger"), 4'000);
  EXPECT_TRUE(std::isfinite(v));
  EXPECT_EQ(seen.block, "bigger");
  EXPECT_EQ(seen.count, 5u);  // steps 0..4
  EXPECT_EQ(p.health()[1].non_finite, 5u);
  EXPECT_EQ(p.health()[0].non_finite, 0u);
}

TEST(PlantSet, AnInputReadsAnotherPlant) {
  PlantSpec src;
  src.name = "src";
  src.inputs.push_back(time_input("r", {RampSpec{0.0, 10.0, 0.0, 10.0}}));
  src.blocks.push_back(block("g", GainBlock{ref("r"), 2.0}));
  PlantSpec dst;
  dst.name = "dst";
  dst.inputs.push_back(plant_input("x", "src.g"));
  dst.blocks.push_back(block("lag", LagBlock{ref("x"), 1.0, 1.0, 0.0}));
  PlantSet set({src, dst}, 1);
  Plant* d = set.find("dst");
  Plant* s = set.find("src");
  // Reading dst advances src with it; dst saw src at each of its steps.
  EXPECT_NEAR(d->value(d->find("x"), 5'000'000), 10.0, 1e-9);
  EXPECT_GE(s->time(), 5'000'000);
  // A ramp of slope 2 / s through a lag of 1 s: y = 2 (t - 1 + e^-t) (ZOH of a ramp: within a step's worth).
  EXPECT_NEAR(d->value(d->find("lag"), 5'000'000), 2.0 * (5.0 - 1.0 + std::exp(-5.0)), 2.0 * 1e-3);
  PlantVar var = kNoVar;
  std::string why;
  EXPECT_EQ(set.resolve("nope.x", var, &why), nullptr);
  EXPECT_NE(why.find("no plant 'nope' (plants: src, dst)"), std::string::npos) << why;
}

TEST(PlantSet, PlantsReadingEachOtherAreRefused) {
  PlantSpec a;
  a.name = "a";
  a.inputs.push_back(plant_input("x", "b.y"));
  a.blocks.push_back(block("y", GainBlock{ref("x"), 1.0}));
  PlantSpec b = a;
  b.name = "b";
  b.inputs[0].plant_ref = "a.y";
  EXPECT_THROW(PlantSet({a, b}, 1), PlantError);
}

TEST(PlantSet, ASensorReadsAPlantVariable) {
  PlantSet set({rig("vessel")}, 1);
  PlantSetResolver resolver(set);
  ProcessSpec spec;
  spec.pressure = {PlantTermSpec{"vessel.pressure", "f.yaml:30:17: nodes[0].physics.pressure.plant"},
                   ConstantSpec{-1.01325 * kBar}};  // gauge
  spec.temperature = {ConstantSpec{293.15}};
  ProcessModel model(spec, 1, &resolver, 10'000);
  Plant* p = set.find("vessel");
  EXPECT_DOUBLE_EQ(model.at(2.0).pressure_pa, p->value(p->find("pressure"), 2'000'000) - 1.01325 * kBar);
  EXPECT_TRUE(model.reads_plant());
  spec.pressure = {PlantTermSpec{"vessel.mass", "f.yaml:30:17: nodes[0].physics.pressure.plant"}};
  try {
    ProcessModel bad(spec, 1, &resolver, 0);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "f.yaml:30:17: nodes[0].physics.pressure.plant: plant variable vessel.mass is a mass; the pressure "
                 "channel needs a pressure");
  }
  // Without plants (a profile checked on its own): the term says what it needs.
  spec.pressure = {PlantTermSpec{"vessel.pressure", "x.yaml:4:3: physics.pressure.plant"}};
  EXPECT_THROW(ProcessModel(spec, 1), std::invalid_argument);
}

TEST(PlantSet, TwoSensorsOnOneVesselDisagreeOnlyAsTheirSensorsDo) {
  PlantSet set({rig("vessel")}, 1);
  PlantSetResolver resolver(set);
  const ProcessSpec spec = reads_vessel();
  SensorSpec sensor = pressure_sensor();
  sensor.pressure.noise_rms = 0.0;
  Sensor a(sensor, ProcessModel(spec, 1, &resolver, 1'000'000), 11);
  sensor.pressure.noise_rms = 0.002 * kBar;
  sensor.pressure.sample_rate_hz = 100;
  Sensor b(sensor, ProcessModel(spec, 2, &resolver, 1'000'000), 12);
  set.find("vessel")->set_input(1, 0.3, 500'000);
  for (TimeUs t = 0; t <= 3'000'000; t += 7'000) {
    const auto& ra = a.read(t);
    if (t % 21'000 == 0) {
      const auto& rb = b.read(t);
      // b samples at 100 Hz: its latest sample is at most 10 ms old.
      const double truth_b =
          set.find("vessel")->value(set.find("vessel")->find("pressure"), rb.pressure.sample_time_us);
      EXPECT_DOUBLE_EQ(rb.pressure.truth, truth_b);
      EXPECT_NEAR(rb.pressure.value, truth_b, 0.01 * kBar);
    }
    EXPECT_DOUBLE_EQ(ra.pressure.truth,
                     set.find("vessel")->value(set.find("vessel")->find("pressure"), ra.pressure.sample_time_us));
  }
}

// The step path allocates nothing: stepping, inputs, fault edges, history,
// a sensor reading the plant, another plant read through an input.
TEST(Plant, TheStepPathDoesNotAllocate) {
  if (!cansim::test::kCountingNew) GTEST_SKIP() << "allocation counting disabled under AddressSanitizer";
  PlantSpec src;
  src.name = "src";
  src.inputs.push_back(time_input("w", {ConstantSpec{0.5}, SineSpec{0.1, 2.0, 0.0}}));
  src.blocks.push_back(block("g", SecondOrderBlock{ref("w"), 3.0, 0.4, 1.0}));
  PlantSpec vessel = rig("vessel");
  vessel.inputs[1].source = PlantInputSpec::Source::kPlant;
  vessel.inputs[1].plant_ref = "src.g";
  vessel.inputs[0].timeout_us = 300'000;
  vessel.inputs[0].on_timeout = 1e-3;
  PlantFaultSpec leak;
  leak.fault.kind = FaultKind::Leak;
  leak.fault.leak_kv = 0.05;
  leak.fault.timing.at_us = 2'000'000;
  leak.fault.timing.duration_us = 500'000;
  leak.fault.timing.period_us = 1'000'000;
  leak.target = "vessel";
  vessel.faults.push_back(leak);
  PlantSet set({src, vessel}, 3);
  PlantSetResolver resolver(set);
  Sensor s(pressure_sensor(), ProcessModel(reads_vessel(), 1, &resolver, 100'000), 5);
  Plant* p = set.find("vessel");
  s.read(0);
  const long before = cansim::test::g_allocations.load();
  for (TimeUs t = 0; t <= 10'000'000; t += 10'000) {
    if (t % 200'000 == 0) p->set_input(0, 4e-3 + 1e-4 * double(t % 1'000'000) / 1e6, t);
    s.read(t);
  }
  EXPECT_EQ(cansim::test::g_allocations.load() - before, 0);
  EXPECT_GE(p->time(), 10'000'000);
}
