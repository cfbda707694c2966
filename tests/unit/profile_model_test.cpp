// The typed profile model without any file: a personality runs from plain
// structs (layout, settings, physics), and the CiA 404 chain binds to
// whatever channels the layout has.
#include <gtest/gtest.h>

#include "model/profile.hpp"
#include "personalities/dps.hpp"
#include "personalities/registry.hpp"
#include "support/sim.hpp"

namespace cansim::test {
namespace {

OdEntry var(std::uint16_t index, std::uint8_t sub, DataType type, Access access, std::vector<std::uint8_t> def,
            ObjectKind kind = ObjectKind::kArray) {
  OdEntry e;
  e.index = index;
  e.sub = sub;
  e.kind = kind;
  e.type = type;
  e.access = access;
  e.capacity = std::uint32_t(type_size(type));
  e.default_bytes = std::move(def);
  return e;
}

std::vector<std::uint8_t> le32(std::uint32_t v) {
  return {std::uint8_t(v), std::uint8_t(v >> 8), std::uint8_t(v >> 16), std::uint8_t(v >> 24)};
}

// A one-channel pressure sensor in bar: the CiA 301 minimum and 0x6130 / 0x6131 / 0x6150.
model::Profile plain_dps(bool span_overflow_emcy) {
  model::Profile p;
  p.personality = "honeywell-dps";
  p.node_id = 5;
  p.options = std::make_shared<NodeOptions>();
  p.layout = std::make_shared<OdLayout>();
  OdLayout& od = *p.layout;
  od.add(var(0x1000, 0, DataType::kUnsigned32, Access::kRo, le32(0x00020194), ObjectKind::kVar));
  od.add(var(0x1001, 0, DataType::kUnsigned8, Access::kRo, {0}, ObjectKind::kVar));
  od.add(var(0x1018, 0, DataType::kUnsigned8, Access::kConst, {1}, ObjectKind::kRecord));
  od.add(var(0x1018, 1, DataType::kUnsigned32, Access::kRo, le32(0x0000015A), ObjectKind::kRecord));
  od.add(var(0x6130, 0, DataType::kUnsigned8, Access::kConst, {1}));
  od.add(var(0x6130, 1, DataType::kReal32, Access::kRo, le32(0)));
  od.add(var(0x6131, 0, DataType::kUnsigned8, Access::kConst, {1}));
  od.add(var(0x6131, 1, DataType::kUnsigned32, Access::kRw, le32(0x004E0000)));  // bar
  od.add(var(0x6150, 0, DataType::kUnsigned8, Access::kConst, {1}));
  od.add(var(0x6150, 1, DataType::kUnsigned8, Access::kRo, {0}));
  od.finalize();
  p.cia404 = model::Cia404Profile::discover(od);
  model::DpsSettings dps;
  dps.span_overflow_emcy = span_overflow_emcy;
  p.device = dps;
  p.physics.process.pressure = {physics::ConstantSpec{2.0e5}};
  p.physics.process.temperature = {physics::ConstantSpec{293.15}};
  p.physics.sensor.pressure.range_min = 0.0;
  p.physics.sensor.pressure.range_max = 10.0e5;
  p.physics.sensor.temperature.range_min = 233.15;
  p.physics.sensor.temperature.range_max = 398.15;
  return p;
}

TEST(ProfileModel, ChainBindsToTheLayoutsChannels) {
  const model::Profile p = plain_dps(true);
  ASSERT_EQ(p.cia404->channels.size(), 1u);
  const model::ChannelConfig& c = p.cia404->channels[0];
  EXPECT_EQ(c.source, physics::Channel::Pressure);
  EXPECT_EQ(c.fixed_unit.code, 0x004E0000u);
  EXPECT_EQ(c.param(model::Role::kPv).views[0], p.layout->find(0x6130, 1));
  EXPECT_FALSE(c.param(model::Role::kOffset).present());
  EXPECT_EQ(p.layout->find(0x6130, 1)->hooks, kHookRead);
  EXPECT_EQ(p.layout->find(0x6131, 1)->hooks, kHookWrite);
  EXPECT_EQ(p.cia404->binding(*p.layout->find(0x6150, 1)).role, model::Role::kStatus);
}

TEST(ProfileModel, PersonalityRunsFromPlainStructs) {
  const model::Profile p = plain_dps(false);
  auto app = personalities::make_application(p, {});
  ASSERT_TRUE(app);
  EXPECT_NE(dynamic_cast<personalities::dps::DpsApplication*>(app.get()), nullptr);
  SimBus bus;
  SimNode& n = bus.add(p, p.node_id, app.get());
  bus.power_on_all();
  bus.run_for(ms(50));
  std::span<const std::uint8_t> out;
  ASSERT_EQ(n->read(0x6130, 1, bus.now(), out), SdoAbort::kNone);
  EXPECT_NEAR(decode_f(DataType::kReal32, out.data()), 2.0, 0.05);
}

}  // namespace
}  // namespace cansim::test
