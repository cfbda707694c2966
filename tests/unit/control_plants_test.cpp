// The plants over the control API (io.cansim.Plant1, Fleet1 ListPlants /
// GetPlant / ListPlantSignals) on a real sd-bus peer connection, fake clock:
// variables and inputs in units with their age, overrides, faults with their
// signals, and what is refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "control/names.hpp"
#include "support/control_fleet.hpp"

namespace cansim::test {
namespace {

constexpr const char* kFleet = R"(
interfaces: {vcan0: {}}
plants:
  vessel:
    inputs:
      pump_speed: {unit: '%', frame: {interface: vcan0, id: 0x300, byte: 0, length: 16, scale: 0.01}, timeout: 1 s, on_timeout: 0 %}
      valve: {unit: '%', initial: 50 %}
      wave: {unit: bar, time: [{constant: 0 bar}, {sine: {amplitude: 0.1 bar, period: 1 s}}]}
    blocks:
      tank: {type: gas_volume, volume: 2 l, pressure: 3 bar, inflow: pump, outflow: vent}
      pump: {type: compressor, flow: 600 Nl/min, speed: pump_speed, outlet: tank.pressure}
      vent: {type: valve, kv: 0.5, upstream: tank.pressure, opening: valve}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 0x10, name: pt, physics: {pressure: {plant: vessel.pressure}}}
)";

class ControlPlantsTest : public ::testing::Test {
 protected:
  ControlFleet fleet{kFleet};
  BusPair bus{fleet.service()};
  std::string last_error;
  std::string last_unit;

  std::string plant_path(const std::string& name) {
    sd_bus_message* m = bus.fleet_call("GetPlant");
    sd_bus_message_append(m, "s", name.c_str());
    std::string error;
    sd_bus_message* r = bus.call(m, &error, &last_error);
    if (!r) return "!" + error;
    const char* p = nullptr;
    sd_bus_message_read(r, "o", &p);
    std::string out = p;
    sd_bus_message_unref(r);
    return out;
  }
  sd_bus_message* plant_call(const char* member) {
    sd_bus_message* m = nullptr;
    sd_bus_message_new_method_call(bus.client(), &m, nullptr, plant_path("vessel").c_str(), control::kPlantInterface,
                                   member);
    return m;
  }
  // Calls a plant method; "" when done, else the error name.
  template <typename... Args>
  std::string call(const char* member, const char* sig, Args... args) {
    sd_bus_message* m = plant_call(member);
    if (sig && *sig) sd_bus_message_append(m, sig, args...);
    std::string name;
    sd_bus_message* r = bus.call(m, &name, &last_error);
    if (r) sd_bus_message_unref(r);
    return r ? "" : name;
  }
  double get(const char* variable, const char* unit) {
    sd_bus_message* m = plant_call("Get");
    sd_bus_message_append(m, "ss", variable, unit);
    std::string name;
    sd_bus_message* r = bus.call(m, &name, &last_error);
    double v = NAN;
    const char* u = nullptr;
    if (r) sd_bus_message_read(r, "ds", &v, &u), last_unit = u, sd_bus_message_unref(r);
    return v;
  }
  sd_bus_message* property(const char* name) {
    sd_bus_message* m = nullptr;
    sd_bus_message_new_method_call(bus.client(), &m, nullptr, plant_path("vessel").c_str(),
                                   "org.freedesktop.DBus.Properties", "Get");
    sd_bus_message_append(m, "ss", control::kPlantInterface, name);
    return bus.call(m);
  }
  struct Var {
    std::string kind;
    double value;
    std::string unit;
  };
  std::map<std::string, Var> variables() {
    sd_bus_message* r = property("Variables");
    std::map<std::string, Var> out;
    if (!r) return out;
    sd_bus_message_enter_container(r, 'v', "a(ssds)");
    sd_bus_message_enter_container(r, 'a', "(ssds)");
    const char *n = nullptr, *k = nullptr, *u = nullptr;
    double v = 0;
    while (sd_bus_message_read(r, "(ssds)", &n, &k, &v, &u) > 0) out[n] = {k, v, u};
    sd_bus_message_unref(r);
    return out;
  }
  struct Input {
    double value;
    std::string unit;
    std::int64_t updated;
    std::string source;
    int overridden, stuck, lost, timed_out;
  };
  std::map<std::string, Input> inputs() {
    sd_bus_message* r = property("Inputs");
    std::map<std::string, Input> out;
    if (!r) return out;
    sd_bus_message_enter_container(r, 'v', "a(sdsxsbbbb)");
    sd_bus_message_enter_container(r, 'a', "(sdsxsbbbb)");
    const char *n = nullptr, *u = nullptr, *src = nullptr;
    Input in{};
    while (sd_bus_message_read(r, "(sdsxsbbbb)", &n, &in.value, &u, &in.updated, &src, &in.overridden, &in.stuck,
                               &in.lost, &in.timed_out) > 0) {
      in.unit = u;
      in.source = src;
      out[n] = in;
    }
    sd_bus_message_unref(r);
    return out;
  }
  void send_pump(unsigned hundredths) {
    fleet.receive("vcan0", CanFrame::make(0x300, {std::uint8_t(hundredths), std::uint8_t(hundredths >> 8)}));
  }
};

TEST_F(ControlPlantsTest, PlantsAreListedAndFoundByName) {
  sd_bus_message* r = bus.call(bus.fleet_call("ListPlants"));
  ASSERT_NE(r, nullptr);
  sd_bus_message_enter_container(r, 'a', "(os)");
  const char *path = nullptr, *name = nullptr;
  ASSERT_GT(sd_bus_message_read(r, "(os)", &path, &name), 0);
  EXPECT_STREQ(path, "/io/cansim/Cansimd1/plant/vessel");
  EXPECT_STREQ(name, "vessel");
  sd_bus_message_unref(r);
  EXPECT_EQ(plant_path("tank"), "!io.cansim.Error.UnknownPlant");
  EXPECT_EQ(last_error, "no plant 'tank' (plants: vessel)");
}

TEST_F(ControlPlantsTest, VariablesInTheirUnitsAndInputsWithTheirAge) {
  send_pump(4000);  // 40 %
  fleet.run_until(ms(500));
  const auto vars = variables();
  ASSERT_TRUE(vars.count("tank.pressure"));
  EXPECT_EQ(vars.at("tank.pressure").unit, "bar");
  EXPECT_EQ(vars.at("tank.pressure").kind, "pressure");
  EXPECT_EQ(vars.at("tank.temperature").unit, "degC");
  EXPECT_NEAR(vars.at("tank.temperature").value, 20.0, 1e-9);
  EXPECT_EQ(vars.at("pump.flow").unit, "g/s");
  EXPECT_NEAR(vars.at("pump_speed").value, 40.0, 1e-9);
  EXPECT_EQ(vars.at("pump_speed").unit, "%");
  // The same value through Get, in any unit of its kind.
  const double bar = get("pressure", "");
  EXPECT_EQ(last_unit, "bar");
  EXPECT_NEAR(get("tank.pressure", "kPa"), bar * 100.0, 1e-6);
  EXPECT_EQ(last_unit, "kPa");
  EXPECT_NEAR(get("pump.flow", "kg/h"), vars.at("pump.flow").value * 3.6, 1e-9);
  EXPECT_TRUE(std::isnan(get("pressure", "degC")));
  EXPECT_NE(last_error.find("unit 'degC' is not one of a pressure"), std::string::npos) << last_error;
  EXPECT_TRUE(std::isnan(get("presure", "")));
  EXPECT_NE(last_error.find("plant vessel has no variable 'presure'"), std::string::npos) << last_error;
  const auto ins = inputs();
  EXPECT_EQ(ins.at("pump_speed").updated, 0);  // the frame at t = 0
  EXPECT_EQ(ins.at("pump_speed").source, "frame vcan0 0x300 bit 0 +16 little unsigned");
  EXPECT_EQ(ins.at("valve").updated, -1);  // never set
  EXPECT_EQ(ins.at("valve").source, "the control API");
  EXPECT_EQ(ins.at("wave").source, "time terms");
  EXPECT_EQ(ins.at("wave").unit, "bar");
}

TEST_F(ControlPlantsTest, OverrideWinsOverTheFramesAndSetActsAsAFrame) {
  send_pump(4000);
  fleet.run_until(ms(10));
  EXPECT_EQ(call("Override", "sds", "pump_speed", 75.0, "%"), "");
  send_pump(1000);
  fleet.run_until(ms(20));
  EXPECT_NEAR(get("pump_speed", "%"), 75.0, 1e-9);
  EXPECT_TRUE(inputs().at("pump_speed").overridden);
  EXPECT_EQ(call("ClearOverride", "s", "pump_speed"), "");
  fleet.run_until(ms(30));
  EXPECT_NEAR(get("pump_speed", "%"), 10.0, 1e-9);
  // Set: an input the control API feeds; refused for one a source replaces at once.
  EXPECT_EQ(call("Set", "sds", "valve", 0.3, ""), "");  // "" : the input's unit, %
  fleet.run_until(ms(40));
  EXPECT_NEAR(get("valve", ""), 0.3, 1e-12);
  EXPECT_EQ(call("Set", "sds", "wave", 1.0, "bar"), "io.cansim.Error.InvalidArgument");
  EXPECT_NE(last_error.find("input wave reads time terms"), std::string::npos) << last_error;
  EXPECT_EQ(call("Override", "sds", "valve", 40.0, "bar"), "io.cansim.Error.UnknownUnit");
  EXPECT_EQ(call("Override", "sds", "vlave", 40.0, "%"), "io.cansim.Error.UnknownVariable");
  EXPECT_EQ(call("Override", "sds", "valve", NAN, "%"), "io.cansim.Error.OutOfRange");
}

TEST_F(ControlPlantsTest, FaultsAreArmedListedSignalledAndCancelled) {
  sd_bus_message* s = bus.call(bus.fleet_call("Subscribe"));
  ASSERT_NE(s, nullptr);
  sd_bus_message_unref(s);
  send_pump(6000);
  fleet.run_until(ms(100));
  sd_bus_message* m = plant_call("ArmFault");
  sd_bus_message_append(m, "s", "leak");
  sd_bus_message_append(m, "a{ss}", 4, "target", "tank", "kv", "0.1", "after", "1 s", "duration", "2 s");
  std::string error;
  sd_bus_message* r = bus.call(m, &error, &last_error);
  ASSERT_NE(r, nullptr) << error << " " << last_error;
  std::uint32_t id = 99;
  sd_bus_message_read(r, "u", &id);
  sd_bus_message_unref(r);
  fleet.run_until(ms(1100));  // nobody reads: the edge still comes on time
  fleet.run_until(ms(3200));
  bus.pump();
  std::vector<std::pair<std::string, std::int64_t>> seen;
  for (auto& [name, msg] : bus.take_signals()) {
    if (name == "FaultStarted" || name == "FaultEnded") {
      std::int64_t t = 0;
      std::uint32_t fid = 0;
      const char *kind = nullptr, *target = nullptr;
      sd_bus_message_read(msg, "xuss", &t, &fid, &kind, &target);
      EXPECT_EQ(fid, id);
      EXPECT_STREQ(kind, "leak");
      EXPECT_STREQ(target, "tank");
      seen.emplace_back(name, t);
    }
    sd_bus_message_unref(msg);
  }
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0], std::make_pair(std::string("FaultStarted"), std::int64_t(ms(1100))));
  EXPECT_EQ(seen[1], std::make_pair(std::string("FaultEnded"), std::int64_t(ms(3100))));
  // Refused: a kind that does not fit the target, a node fault, a missing target.
  auto arm = [&](const char* kind, const char* key, const char* value) {
    sd_bus_message* a = plant_call("ArmFault");
    sd_bus_message_append(a, "s", kind);
    sd_bus_message_append(a, "a{ss}", 1, key, value);
    std::string name;
    sd_bus_message* res = bus.call(a, &name, &last_error);
    if (res) sd_bus_message_unref(res);
    return res ? std::string() : name;
  };
  EXPECT_EQ(arm("blocked", "target", "tank"), "io.cansim.Error.InvalidArgument");
  EXPECT_NE(last_error.find("blocked: expected a valve, pump or line as target, got 'tank'"), std::string::npos)
      << last_error;
  EXPECT_EQ(arm("open", "target", "tank"), "io.cansim.Error.UnknownFault");
  EXPECT_EQ(arm("valve_stuck", "kv", "1"), "io.cansim.Error.InvalidArgument");
  // Armed until cancelled, then gone from the list.
  const std::string ok = arm("input_lost", "target", "pump_speed");
  EXPECT_EQ(ok, "");
  fleet.run_until(ms(3300));
  send_pump(1000);  // lost: not taken, the command's timeout (1 s since the last frame at 0 s) shows
  fleet.run_until(ms(3400));
  EXPECT_NEAR(get("pump_speed", "%"), 0.0, 1e-9);
  EXPECT_TRUE(inputs().at("pump_speed").lost);
  EXPECT_TRUE(inputs().at("pump_speed").timed_out);
  EXPECT_EQ(inputs().at("pump_speed").updated, 0);
  EXPECT_EQ(call("CancelFault", "u", std::uint32_t(1)), "");
  EXPECT_EQ(call("CancelFault", "u", std::uint32_t(1)), "io.cansim.Error.UnknownFault");
}

TEST_F(ControlPlantsTest, FrameSignalsAreListedForAMonitor) {
  sd_bus_message* r = bus.call(bus.fleet_call("ListPlantSignals"));
  ASSERT_NE(r, nullptr);
  sd_bus_message_enter_container(r, 'a', "(sssubqyybdds)");
  const char *plant = nullptr, *input = nullptr, *iface = nullptr, *unit = nullptr;
  std::uint32_t id = 0;
  int extended = 0, little = 0;
  std::uint16_t start = 0;
  std::uint8_t length = 0, type = 0;
  double scale = 0, offset = 0;
  ASSERT_GT(sd_bus_message_read(r, "(sssubqyybdds)", &plant, &input, &iface, &id, &extended, &start, &length, &type,
                                &little, &scale, &offset, &unit),
            0);
  EXPECT_STREQ(plant, "vessel");
  EXPECT_STREQ(input, "pump_speed");
  EXPECT_STREQ(iface, "vcan0");
  EXPECT_EQ(id, 0x300u);
  EXPECT_EQ(length, 16);
  EXPECT_EQ(little, 1);
  EXPECT_DOUBLE_EQ(scale, 0.01);
  EXPECT_STREQ(unit, "%");
  sd_bus_message_unref(r);
}

}  // namespace
}  // namespace cansim::test
