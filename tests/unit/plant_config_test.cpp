// A fleet's `plants:` and the plant bindings of its nodes (config/plant_config.*):
// what loads, and every refusal naming file:line:column: key.
#include <gtest/gtest.h>

#include <string>

#include "config/fleet.hpp"
#include "config/physics_config.hpp"
#include "daemon/daemon.hpp"

namespace cansim::config {
namespace {

const std::string kProfiles = std::string(CANSIM_SOURCE_DIR) + "/profiles";

ProfileSearch search() {
  ProfileSearch s;
  s.dirs = {kProfiles};
  return s;
}

FleetConfig parse(const std::string& text) { return parse_fleet(text, "f.yaml", search()); }

std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

// The closed loop of examples/closed_loop, cut down: a vessel, a pump on a
// frame signal, a vent on the actuator's output 1, one transmitter.
std::string fleet(const std::string& plant_extra = "", const std::string& node_physics = "{plant: vessel.pressure}") {
  return "interfaces: {vcan0: {}}\n"
         "plants:\n"
         "  vessel:\n"
         "    inputs:\n"
         "      pump_speed: {unit: '%', frame: {interface: vcan0, id: 0x300, byte: 0, length: 16, scale: 0.01}, "
         "timeout: 1 s, on_timeout: 0 %}\n"
         "      valve: {unit: '%', node: {name: act, output: 1}, scale: 0.01}\n"
         "    blocks:\n"
         "      tank: {type: gas_volume, volume: 2 l, pressure: 1 atm, inflow: pump, outflow: vent}\n"
         "      pump: {type: compressor, flow: 600 Nl/min, speed: pump_speed, outlet: tank.pressure}\n"
         "      vent: {type: valve, kv: 0.5, upstream: tank.pressure, opening: valve}\n" +
         plant_extra +
         "nodes:\n"
         "  - {profile: actuator-401, interface: vcan0, name: act}\n"
         "  - {profile: generic-404, interface: vcan0, node_id: 0x10, name: pt, physics: {pressure: " +
         node_physics + "}}\n";
}

}  // namespace

TEST(PlantConfig, TheClosedLoopLoads) {
  const FleetConfig f = parse(fleet());
  ASSERT_EQ(f.plants.specs.size(), 1u);
  const physics::PlantSpec& p = f.plants.specs[0];
  EXPECT_EQ(p.name, "vessel");
  EXPECT_EQ(p.step_us, 1000);
  ASSERT_EQ(p.inputs.size(), 2u);
  EXPECT_EQ(p.inputs[0].kind, physics::QuantityKind::kFraction);
  EXPECT_EQ(p.inputs[0].timeout_us, 1'000'000);
  EXPECT_EQ(*p.inputs[0].on_timeout, 0.0);
  EXPECT_EQ(p.inputs[1].source, physics::PlantInputSpec::Source::kExternal);
  ASSERT_EQ(f.plants.bindings.size(), 2u);
  const PlantInputBinding& frame = f.plants.bindings[0];
  EXPECT_EQ(frame.kind, PlantInputBinding::Kind::kFrame);
  EXPECT_EQ(frame.signal.can_id, 0x300u);
  EXPECT_EQ(frame.signal.length, 16);
  EXPECT_DOUBLE_EQ(frame.signal.scale, 0.01);
  EXPECT_EQ(f.plants.bindings[1].node_key, "vcan0/act/0");
  const auto& tank = std::get<physics::GasVolumeBlock>(p.blocks[0].params);
  EXPECT_DOUBLE_EQ(tank.volume_m3, 2e-3);
  EXPECT_DOUBLE_EQ(tank.initial_pressure_pa, 101325.0);
  const auto& pump = std::get<physics::PumpBlock>(p.blocks[1].params);
  EXPECT_NEAR(pump.nominal_flow_kgs, 600.0 / 60000 * 101325.0 / (287.05 * 273.15), 1e-12);  // normal litres of air
  // The node reading the plant: a plant term, and --check builds it.
  const auto& terms = f.nodes[1].profile->physics.process.pressure;
  ASSERT_EQ(terms.size(), 1u);
  EXPECT_EQ(std::get<physics::PlantTermSpec>(terms[0]).ref, "vessel.pressure");
  FleetConfig copy = f;
  EXPECT_EQ(daemon::check_fleet(copy), "f.yaml: ok, 2 node(s) on 1 interface(s), 1 plant(s)");
}

TEST(PlantConfig, ANodeReadingAPlantRestartsWhenThePlantsChange) {
  const FleetConfig a = parse(fleet());
  const FleetConfig b = parse(fleet("    step: 2 ms\n"));
  EXPECT_NE(a.nodes[1].fingerprint, b.nodes[1].fingerprint);  // reads the plant
  EXPECT_EQ(a.nodes[0].fingerprint, b.nodes[0].fingerprint);  // feeds it: keeps running
}

TEST(PlantConfig, BadBlocksUnitsAndNamesNameTheirPlace) {
  EXPECT_EQ(error_of(fleet("      x: {type: lagg, in: valve}\n"))
                .rfind("f.yaml:11:17: plants.vessel.blocks.x.type: unknown block type", 0),
            0u)
      << error_of(fleet("      x: {type: lagg, in: valve}\n"));
  std::string e = error_of(fleet("      x: {type: lag, in: valve, time_constant: 2 parsecs}\n"));
  EXPECT_EQ(e.rfind("f.yaml:11:48: plants.vessel.blocks.x.time_constant: expected a time", 0), 0u) << e;
  e = error_of(fleet("      x: {type: lag, in: vlave, time_constant: 1 s}\n"));
  EXPECT_EQ(e.rfind("f.yaml:11:26: plants.vessel.blocks.x.in: unknown name 'vlave'", 0), 0u) << e;
  e = error_of(fleet("      x: {type: lag, in: valve, time_constant: 0 s}\n"));
  EXPECT_EQ(e.rfind("f.yaml:11:48: plants.vessel.blocks.x.time_constant: expected a time constant > 0", 0), 0u) << e;
  e = error_of(fleet("      x: {type: gain, in: valve, k: 1, unit: furlong}\n"));
  EXPECT_EQ(e.rfind("f.yaml:11:46: plants.vessel.blocks.x.unit: expected a unit", 0), 0u) << e;
  e = error_of(fleet("      x: {type: gas_volume, volume: -2 l}\n"));
  EXPECT_EQ(e.rfind("f.yaml:11:37: plants.vessel.blocks.x.volume: expected a volume > 0", 0), 0u) << e;
  e = error_of(fleet("      x: {type: gain, in: 3 bar}\n"));
  EXPECT_EQ(e.rfind("f.yaml:11:27: plants.vessel.blocks.x.in: expected a number without a unit, got '3 bar'", 0), 0u)
      << e;
  e = error_of(fleet("      x: {type: gain, in: valve, k: 1, volume: 2 l}\n"));
  EXPECT_NE(e.find("plants.vessel.blocks.x.volume: unknown key"), std::string::npos) << e;
  e = error_of(fleet("      x: {type: valve, kv: 1, upstream: 3 degC}\n"));
  EXPECT_EQ(e.rfind("f.yaml:11:41: plants.vessel.blocks.x.upstream: expected a pressure", 0), 0u) << e;
}

TEST(PlantConfig, AnAlgebraicLoopIsRefusedAtLoadNamingTheCycle) {
  const std::string e =
      error_of(fleet("      a: {type: gain, in: b, k: 0.5}\n      b: {type: offset, in: a, offset: 1}\n"));
  EXPECT_EQ(e.rfind("f.yaml:11:10: plants.vessel.blocks.a: algebraic loop a -> b -> a", 0), 0u) << e;
}

TEST(PlantConfig, BadInputsNameTheirPlace) {
  std::string e = error_of(
      "interfaces: {vcan0: {}}\nplants:\n  p:\n    inputs:\n      u: {unit: '%', frame: {interface: vcan9, id: "
      "0x300}}\n"
      "    blocks: {g: {type: gain, in: u}}\nnodes: [{profile: generic-404, interface: vcan0}]\n");
  EXPECT_EQ(e.rfind("f.yaml:5:29: plants.p.inputs.u.frame: expected an interface of the fleet (vcan0), got 'vcan9'", 0),
            0u)
      << e;
  e = error_of(
      "interfaces: {vcan0: {}}\nplants:\n  p:\n    inputs:\n      u: {unit: '%', frame: {interface: vcan0, id: 0x300, "
      "start: 60, length: 16}}\n    blocks: {g: {type: gain, in: u}}\nnodes: [{profile: generic-404, interface: "
      "vcan0}]\n");
  EXPECT_EQ(e.rfind("f.yaml:5:29: plants.p.inputs.u.frame: the signal does not fit in 8 bytes", 0), 0u) << e;
  e = error_of(
      "interfaces: {vcan0: {}}\nplants:\n  p:\n    inputs:\n      u: {unit: degrees}\n"
      "    blocks: {g: {type: gain, in: u}}\nnodes: [{profile: generic-404, interface: vcan0}]\n");
  EXPECT_EQ(e.rfind("f.yaml:5:17: plants.p.inputs.u.unit: expected a unit", 0), 0u) << e;
  // A node input: an unknown node, an object it lacks, a read-only object, outputs of a node that has none.
  auto with_node = [](const std::string& node) {
    return "interfaces: {vcan0: {}}\nplants:\n  p:\n    inputs:\n      u: {node: " + node +
           "}\n    blocks: {g: {type: gain, in: u}}\nnodes: [{profile: generic-404, interface: vcan0, name: pt}]\n";
  };
  e = error_of(with_node("{name: valve, object: 0x2100:01}"));
  EXPECT_EQ(e.rfind("f.yaml:5:17: plants.p.inputs.u.node: no node 'valve' in the fleet", 0), 0u) << e;
  e = error_of(with_node("{name: pt, object: 0x2100:07}"));
  EXPECT_EQ(e.rfind("f.yaml:5:17: plants.p.inputs.u.node: node pt (profile generic-404) has no object 0x2100:07", 0),
            0u)
      << e;
  e = error_of(with_node("{name: pt, object: 0x1000:00}"));
  EXPECT_NE(e.find("is read-only: a master never writes it"), std::string::npos) << e;
  e = error_of(with_node("{name: pt, output: 1}"));
  EXPECT_NE(e.find("node pt (personality generic) has no outputs"), std::string::npos) << e;
  EXPECT_EQ(error_of(with_node("{name: pt, object: 0x2100:01}")), "no error");
}

TEST(PlantConfig, ASensorBindingNamesAVariableThatExistsAndFits) {
  std::string e = error_of(fleet("", "{plant: vessel.presure}"));
  EXPECT_EQ(e.rfind("f.yaml:13:99: nodes[1].physics.pressure.plant: plant vessel has no variable 'presure'", 0), 0u)
      << e;
  e = error_of(fleet("", "{plant: tank.pressure}"));
  EXPECT_EQ(e.rfind("f.yaml:13:99: nodes[1].physics.pressure.plant: no plant 'tank' (plants: vessel)", 0), 0u) << e;
  e = error_of(fleet("", "{plant: vessel.mass}"));
  EXPECT_NE(e.find("plant variable vessel.mass is a mass; the pressure channel needs a pressure"), std::string::npos)
      << e;
  e = error_of(fleet("", "{plant: vessel}"));
  EXPECT_NE(e.find("expected PLANT.VARIABLE"), std::string::npos) << e;
  // Today's terms on top: a gauge transmitter.
  EXPECT_EQ(error_of(fleet("", "[{plant: vessel.pressure}, {constant: -1.01325 bar}]")), "no error");
}

TEST(PlantConfig, PlantFaultsGoOnPlantsAndNodeFaultsOnNodes) {
  std::string e = error_of(fleet("    faults: [{kind: leak, target: tank, kv: 0.05, at: 10 s, duration: 5 s}]\n"));
  EXPECT_EQ(e, "no error");
  e = error_of(fleet("    faults: [{kind: leak, target: vent, kv: 0.05}]\n"));
  EXPECT_NE(e.find("leak: expected a gas_volume as target, got 'vent'"), std::string::npos) << e;
  EXPECT_EQ(e.rfind("f.yaml:11:14: plants.vessel.faults[0]: ", 0), 0u) << e;
  e = error_of(fleet("    faults: [{kind: open, target: tank}]\n"));
  EXPECT_NE(e.find("expected leak, blocked, valve_stuck or input_lost"), std::string::npos) << e;
  e = error_of(fleet("    faults: [{kind: leak, target: tank}]\n"));
  EXPECT_NE(e.find("expected a leak's kv"), std::string::npos) << e;
  e = error_of("interfaces: {vcan0: {}}\nnodes: [{profile: generic-404, interface: vcan0, faults: [{kind: leak}]}]\n");
  EXPECT_NE(
      e.find(
          "nodes[0].faults[0].kind: expected a node fault (leak, blocked, valve_stuck and input_lost are plant faults"),
      std::string::npos)
      << e;
}

TEST(PlantConfig, AProfileReadingAPlantNeedsAFleetThatHasIt) {
  std::string e = error_of(
      "interfaces: {vcan0: {}}\nnodes: [{profile: generic-404, interface: vcan0, physics: {pressure: {plant: "
      "v.p}}}]\n");
  EXPECT_NE(e.find("physics.pressure.plant: no plant 'v' (plants: none)"), std::string::npos) << e;
}

TEST(PlantConfig, NodesAddedAtRunTimeMayReadTheRunningPlantsButBringNone) {
  const FleetConfig running = parse(fleet());
  FleetConfig extra = parse_fleet_fragment(
      "{profile: generic-404, interface: vcan0, node_id: 0x20, name: pt2, physics: {pressure: {plant: "
      "vessel.pressure}}}",
      "<AddNodes #1>", search(), running);
  EXPECT_EQ(extra.nodes.size(), 1u);
  EXPECT_TRUE(extra.plants.empty());
  try {
    parse_fleet_fragment(
        "{nodes: [{profile: generic-404, interface: vcan0, node_id: 0x21}], plants: {q: {blocks: {}}}}",
        "<AddNodes #2>", search(), running);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(
        std::string(e.what()).find("<AddNodes #2>:1:76: plants: plants are defined in the configuration file only"),
        std::string::npos)
        << e.what();
  }
}

}  // namespace cansim::config
