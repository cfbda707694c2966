// cansimctl and plants without a daemon: the plant verb and plant:NAME
// targets as method calls, the plant table and its JSON, and the monitor
// decoding a plant input's frame by name and unit.
#include <gtest/gtest.h>

#include <sstream>

#include "ctl/args.hpp"
#include "ctl/frame_decoder.hpp"
#include "ctl/json.hpp"
#include "ctl/plants.hpp"

namespace cansim::ctl {
namespace {

Request parse(std::vector<std::string> args) { return parse_command_line(args).request; }
Arg s(const char* text) { return Value(std::string(text)); }

TEST(CtlPlants, ThePlantVerbShowsSetsAndOverrides) {
  Request all = parse({"plant"});
  EXPECT_EQ(all.output, Output::kPlant);
  EXPECT_EQ(all.node, "");
  EXPECT_TRUE(all.call.method.empty());
  EXPECT_EQ(parse({"plant", "vessel"}).node, "vessel");
  Request set = parse({"plant", "vessel", "set", "pump", "40", "%"});
  EXPECT_EQ(set.call, (Call{Target::kFleet, kPlantInterface, "Set", {s("pump"), Value(40.0), s("%")}}));
  Request over = parse({"plant", "vessel", "override", "valve", "40"});
  EXPECT_EQ(over.call, (Call{Target::kFleet, kPlantInterface, "Override", {s("valve"), Value(40.0), s("")}}));
  Request off = parse({"plant", "vessel", "override", "valve", "--off"});
  EXPECT_EQ(off.call, (Call{Target::kFleet, kPlantInterface, "ClearOverride", {s("valve")}}));
  EXPECT_THROW(parse_command_line({"plant", "vessel", "bump", "valve", "4"}), UsageError);
  EXPECT_THROW(parse_command_line({"plant", "vessel", "set", "valve"}), UsageError);
  EXPECT_THROW(parse_command_line({"plant", "vessel", "set", "valve", "many"}), UsageError);
  EXPECT_THROW(parse_command_line({"plant", "--off"}), UsageError);
}

TEST(CtlPlants, FaultsTakeAPlantAsPlantName) {
  Request f = parse({"fault", "plant:vessel", "leak", "target=tank", "kv=0.05", "--for", "10s"});
  EXPECT_EQ(plant_target(f.node), "vessel");
  EXPECT_EQ(f.call.method, "ArmFault");
  EXPECT_EQ(std::get<StringMap>(f.call.args[1]).at("target"), "tank");
  EXPECT_EQ(std::get<StringMap>(f.call.args[1]).at("duration"), "10 s");
  EXPECT_EQ(plant_target("vessel"), "");
  EXPECT_EQ(plant_target("vcan0/dps/0"), "");
}

PlantView vessel() {
  PlantView p;
  p.name = "vessel";
  p.step_us = 1000;
  p.time_us = 12'000'000;
  p.variables = {{"tank.pressure", "pressure", 7.01325, "bar"}, {"pump.flow", "mass flow", 10.3, "g/s"}};
  p.inputs = {
      {"pump_speed", 80, "%", 11'990'000, "frame vcan0 0x300 bit 0 +16 little unsigned", false, false, false, false},
      {"valve", 62.5, "%", -1, "output 1 of node actuator", true, false, false, false}};
  p.faults = {{0, "leak", "tank", true}};
  return p;
}

TEST(CtlPlants, APlantPrintsItsValuesInUnitsAndItsInputsWithTheirAge) {
  std::ostringstream out;
  print_plant_text(out, vessel(), 12'000'000);
  const std::string text = out.str();
  EXPECT_NE(text.find("vessel (step 0.001000 s, at 12.000000 s)"), std::string::npos) << text;
  EXPECT_NE(text.find("tank.pressure  pressure   7.01325  bar"), std::string::npos) << text;
  EXPECT_NE(text.find("pump.flow      mass flow  10.3     g/s"), std::string::npos) << text;
  EXPECT_NE(text.find("pump_speed  80     %     0.010000 s  -           frame vcan0 0x300"), std::string::npos) << text;
  EXPECT_NE(text.find("valve       62.5   %     never       overridden  output 1 of node actuator"), std::string::npos)
      << text;
  EXPECT_NE(text.find("faults: 0 leak on tank (active)"), std::string::npos) << text;
  std::ostringstream json;
  print_plants_json(json, {vessel()}, 12'000'000);
  const Json doc = Json::parse(json.str());
  EXPECT_EQ(doc["time"], 12.0);
  const Json& p = doc["plants"][0];
  EXPECT_EQ(p["plant"], "vessel");
  EXPECT_EQ(p["step"], 0.001);
  EXPECT_EQ(p["variables"][0],
            (Json{{"name", "tank.pressure"}, {"kind", "pressure"}, {"value", 7.01325}, {"unit", "bar"}}));
  EXPECT_EQ(p["inputs"][0]["updated"], 11.99);
  EXPECT_NEAR(p["inputs"][0]["age"].get<double>(), 0.01, 1e-9);
  EXPECT_EQ(p["inputs"][0]["source"], "frame vcan0 0x300 bit 0 +16 little unsigned");
  EXPECT_TRUE(p["inputs"][1]["updated"].is_null());
  EXPECT_TRUE(p["inputs"][1]["age"].is_null());
  EXPECT_EQ(p["inputs"][1]["overridden"], true);
  EXPECT_EQ(p["faults"][0], (Json{{"id", 0}, {"kind", "leak"}, {"target", "tank"}, {"active", true}}));
}

RawFrame frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  RawFrame f;
  f.time = 1.5;
  f.interface = "vcan0";
  f.id = id;
  for (std::uint8_t b : bytes) f.data[f.dlc++] = b;
  return f;
}

TEST(CtlPlants, TheMonitorDecodesAPlantInputByNameAndUnit) {
  FrameDecoder d;
  PlantSignalInfo pump{"vessel", "pump_speed", "vcan0", {}, "%"};
  pump.signal.can_id = 0x300;
  pump.signal.length = 16;
  pump.signal.scale = 0.01;
  PlantSignalInfo heat{"oven", "power", "vcan0", {}, "W"};
  heat.signal.can_id = 0x300;
  heat.signal.start = 23;  // big-endian, bytes 2..3
  heat.signal.length = 16;
  heat.signal.little_endian = false;
  heat.signal.type = CanSignal::Type::kSigned;
  d.set_plant_signals({pump, heat});
  const DecodedFrame f = d.decode(frame(0x300, {0x88, 0x13, 0xFF, 0x38}));  // 5000 x 0.01; 0xFF38 = -200
  EXPECT_EQ(f.kind, "plant");
  ASSERT_EQ(f.fields.size(), 2u);
  EXPECT_EQ(f.fields[0].name, "vessel.pump_speed");
  EXPECT_DOUBLE_EQ(std::get<double>(*f.fields[0].value), 50.0);
  EXPECT_EQ(f.fields[0].unit, "%");
  EXPECT_EQ(f.fields[1].name, "oven.power");
  EXPECT_DOUBLE_EQ(std::get<double>(*f.fields[1].value), -200.0);
  const std::string line = format_decoded(f);
  EXPECT_NE(line.find("vcan0 300 - plant vessel.pump_speed = 50 %, oven.power = -200 W"), std::string::npos) << line;
  // Too short for the signal: not carried; another interface: not this signal.
  EXPECT_EQ(d.decode(frame(0x300, {0x88})).kind, "raw");
  RawFrame other = frame(0x300, {0x88, 0x13});
  other.interface = "vcan1";
  EXPECT_EQ(d.decode(other).kind, "raw");
}

}  // namespace
}  // namespace cansim::ctl
