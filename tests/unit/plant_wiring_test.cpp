// Plants wired into a running fleet (daemon/plant_wiring.*), frame by frame
// on the fake clock: a signal in a frame from the controller, an RPDO into
// the actuator stand-in moving the vent, an SDO-written object, a sensor
// node reporting the plant, and what a timeout and a node's removal do.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "core/can_frame.hpp"
#include "core/node.hpp"
#include "personalities/analog_output.hpp"
#include "personalities/generic.hpp"
#include "personalities/sensor_source.hpp"
#include "physics/plant.hpp"
#include "support/captured_log.hpp"
#include "support/control_fleet.hpp"

namespace cansim {
namespace {

constexpr double kBar = 1e5;

const char* kFleet = R"(
interfaces: {vcan0: {}}
plants:
  vessel:
    inputs:
      pump_speed: {unit: '%', frame: {interface: vcan0, id: 0x300, byte: 0, length: 16, scale: 0.01}, timeout: 1 s, on_timeout: 0 %}
      valve: {unit: '%', node: {name: act, output: 1}, scale: 0.01}
      trim: {unit: '%', node: {name: pt, object: 0x2100:02}, scale: 0.1}
    blocks:
      tank: {type: gas_volume, volume: 2 l, pressure: 3 bar, inflow: pump, outflow: vent}
      pump: {type: compressor, flow: 600 Nl/min, speed: pump_speed, outlet: tank.pressure}
      vent: {type: valve, kv: 0.5, upstream: tank.pressure, opening: valve}
nodes:
  - {profile: actuator-401, interface: vcan0, node_id: 0x30, name: act}
  - {profile: generic-404, interface: vcan0, node_id: 0x10, name: pt, physics: {pressure: {plant: vessel.pressure}}}
)";

class PlantWiringTest : public ::testing::Test {
 protected:
  PlantWiringTest() : fleet(kFleet) {
    plant = fleet.plants()->find("vessel");
    fleet.run_until(ms(10));
    fleet.take("vcan0");
  }
  double input(const char* name) { return plant->input_state(*plant->find_input(name)).value; }
  double var(const char* name, TimeUs t) { return plant->value(plant->find(name), t); }
  void send(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
    fleet.receive("vcan0", CanFrame::make(id, bytes));
  }
  void start_all() { send(0x000, {0x01, 0x00}); }
  // The last frame with `id` sent since the last take, and when.
  std::optional<CanFrame> last(std::uint32_t id, TimeUs* when = nullptr) {
    std::optional<CanFrame> out;
    for (const auto& s : fleet.take("vcan0"))
      if (s.frame.id == id) {
        out = s.frame;
        if (when) *when = s.time;
      }
    return out;
  }
  test::ControlFleet fleet;
  physics::Plant* plant = nullptr;
};

TEST_F(PlantWiringTest, ASignalInAFrameSetsAnInputAndItsTimeoutStopsThePump) {
  fleet.run_until(ms(100));
  send(0x300, {0x88, 0x13});  // 5000 x 0.01 % = 50 %
  fleet.run_until(ms(101));
  EXPECT_DOUBLE_EQ(var("pump_speed", ms(101)), 0.5);
  EXPECT_EQ(plant->input_state(0).updated, ms(100));
  send(0x300, {0x88});        // too short: not carried, ignored
  send(0x301, {0xFF, 0xFF});  // another CAN-ID
  EXPECT_DOUBLE_EQ(var("pump_speed", ms(200)), 0.5);
  EXPECT_GT(var("pump.flow", ms(200)), 0.0);
  // No frame for 1 s: the command is lost, the pump stops.
  EXPECT_DOUBLE_EQ(var("pump_speed", ms(1099)), 0.5);
  EXPECT_DOUBLE_EQ(var("pump_speed", ms(1100)), 0.0);
  EXPECT_TRUE(plant->input_state(0).timed_out);
}

TEST_F(PlantWiringTest, TheActuatorMovesTheVentAsItsTpdoSays) {
  start_all();
  fleet.run_until(ms(20));
  const TimeUs t0 = ms(20);
  send(0x230, {0x88, 0x13, 0, 0, 0, 0, 0, 0});  // RPDO1: 0x6411:01 = 5000 (50.00 %)
  // The vent follows the actuator's first-order response (200 ms).
  for (TimeUs dt : {ms(1), ms(100), ms(200), ms(1000)}) {
    fleet.run_until(t0 + dt);
    EXPECT_NEAR(var("valve", t0 + dt), 0.5 * -std::expm1(-double(dt) / 200e3), 1e-3) << dt;  // a step late at most
  }
  // TPDO1 of the actuator (every 50 ms): 0x6401:01, the actual value, as the plant has it.
  fleet.take("vcan0");
  fleet.run_until(t0 + ms(1100));
  TimeUs sent = 0;
  const std::optional<CanFrame> tpdo = last(0x1B0, &sent);
  ASSERT_TRUE(tpdo);
  const std::int16_t actual = std::int16_t(get_u16(tpdo->data));
  EXPECT_EQ(actual, std::lround(5000 * -std::expm1(-double(sent - t0) / 200e3)));
  EXPECT_NEAR(actual * 1e-4, var("valve", sent), 1e-4);  // the plant's vent at that instant
}

TEST_F(PlantWiringTest, AnObjectAMasterWritesIsAnInput) {
  start_all();
  // SDO download 0x2100:02 (UNSIGNED16) = 250 -> 25.0 %.
  send(0x610, {0x2B, 0x00, 0x21, 0x02, 0xFA, 0x00, 0, 0});
  fleet.run_until(ms(30));
  EXPECT_DOUBLE_EQ(var("trim", ms(30)), 0.25);
  // By RPDO1 of the generic node (0x2100:01 U32, 0x2100:02 U16) as well.
  send(0x210, {0, 0, 0, 0, 0x64, 0x00});
  fleet.run_until(ms(40));
  EXPECT_DOUBLE_EQ(var("trim", ms(40)), 0.10);
}

TEST_F(PlantWiringTest, ASensorNodeReportsThePlant) {
  start_all();
  send(0x300, {0x10, 0x27});  // 100 %: the vessel fills (the vent is closed)
  fleet.run_until(ms(500));
  fleet.take("vcan0");
  fleet.run_until(ms(1000));
  // TPDO1 of generic-404: REAL32 pressure in bar, every 100 ms.
  TimeUs sent = 0;
  const std::optional<CanFrame> tpdo = last(0x190, &sent);
  ASSERT_TRUE(tpdo);
  float bar;
  std::memcpy(&bar, tpdo->data, 4);
  const double truth = var("tank.pressure", sent);  // rising 5 bar/s: read it at the frame's time
  EXPECT_GT(truth, 3.5 * kBar);
  EXPECT_NEAR(bar, truth / kBar, 0.015);  // 1 mbar noise, a 1 ms sample, the 16-bit ADC over 12 bar
}

// An idle node (pre-operational: no PDOs) skips its sensor while the reading
// is steady; a channel on a plant never is (an input may change it at any
// time), and an SDO read after an input change reads the plant as it is then.
TEST_F(PlantWiringTest, AnIdleSensorNodeStillFollowsThePlant) {
  auto& generic = static_cast<personalities::generic::GenericApplication&>(*fleet.node("vcan0/pt/0").app);
  const physics::Sensor& sensor = static_cast<personalities::SensorSource&>(generic.chain().source()).sensor();
  const auto read_bar = [&](TimeUs t, TimeUs& sent) {
    send(0x610, {0x40, 0x30, 0x61, 0x01, 0, 0, 0, 0});  // SDO upload 0x6130:01 (REAL32, bar)
    fleet.run_until(t);
    const std::optional<CanFrame> reply = last(0x590, &sent);
    EXPECT_TRUE(reply && reply->data[0] == 0x43) << "an expedited 4-byte upload";
    float bar = 0;
    if (reply) std::memcpy(&bar, reply->data + 4, 4);
    return bar;
  };
  fleet.run_until(ms(1000));
  TimeUs sent = 0;
  const float before = read_bar(ms(1001), sent);
  EXPECT_NEAR(before, var("tank.pressure", sent) / kBar, 0.015);
  EXPECT_EQ(sensor.steadiness(physics::Channel::Pressure, ms(1001)).until, ms(1001)) << "never steady";
  send(0x300, {0x10, 0x27});  // 100 %: the vessel fills
  fleet.run_until(ms(1500));
  const float after = read_bar(ms(1501), sent);
  EXPECT_GT(after, before + 1.0f);
  EXPECT_NEAR(after, var("tank.pressure", sent) / kBar, 0.015);  // rising 5 bar/s: at the reply's time
}

TEST_F(PlantWiringTest, ARemovedActuatorLeavesTheVentWhereItWas) {
  start_all();
  send(0x230, {0x10, 0x27, 0, 0, 0, 0, 0, 0});  // 100 %
  fleet.run_until(ms(2000));
  const double open = input("valve");
  EXPECT_NEAR(open, 1.0, 1e-3);
  fleet.remove_node("vcan0/act/0");
  fleet.run_until(ms(3000));
  EXPECT_DOUBLE_EQ(var("valve", ms(3000)), open);  // holds its last value
}

TEST_F(PlantWiringTest, LeavingOperationalTheActuatorGoesToItsErrorValue) {
  start_all();
  send(0x230, {0x10, 0x27, 0, 0, 0, 0, 0, 0});  // 100 %
  fleet.run_until(ms(2000));
  send(0x000, {0x80, 0x30});  // pre-operational: error mode 1, error value 0
  fleet.run_until(ms(4000));
  EXPECT_NEAR(var("valve", ms(4000)), 0.0, 1e-3);
}

}  // namespace
}  // namespace cansim

namespace cansim {
namespace {

// A block that overflows: its output keeps its last finite value (here the
// initial 0), the journal names the plant and the block (once per 10 s, not
// once per step), and the sensor reading it sends a finite PDO.
TEST(PlantWiringJournal, ANonFiniteValueIsCountedNamedInTheJournalAndNeverReachesAPdo) {
  test::CapturedLog log;
  test::ControlFleet fleet(R"(
interfaces: {vcan0: {}}
plants:
  p:
    blocks:
      huge: {type: gain, in: 3, k: 1e308, unit: bar}
nodes:
  - {profile: generic-404, interface: vcan0, node_id: 0x10, name: pt, physics: {pressure: {plant: p.huge}}}
)");
  fleet.receive("vcan0", CanFrame::make(0x000, {0x01, 0x00}));
  fleet.run_until(ms(1000));
  bool seen = false;
  for (const auto& s : fleet.take("vcan0")) {
    if (s.frame.id != 0x190) continue;
    float bar;
    std::memcpy(&bar, s.frame.data, 4);
    EXPECT_TRUE(std::isfinite(bar));
    seen = true;
  }
  EXPECT_TRUE(seen) << "TPDO1 of the sensor";
  EXPECT_EQ(log.count("plant p: block huge produced a NaN or an infinity"), 1u) << log.text.str();
  physics::Plant* plant = fleet.plants()->find("p");
  EXPECT_GE(plant->health()[0].non_finite, 1000u);  // every step of the second
}

}  // namespace
}  // namespace cansim
