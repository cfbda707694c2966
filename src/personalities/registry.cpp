#include "personalities/registry.hpp"

#include <variant>

#include "personalities/cmp.hpp"
#include "personalities/dps.hpp"
#include "personalities/gems9000.hpp"
#include "personalities/generic.hpp"
#include "personalities/p92c.hpp"
#include "personalities/smc.hpp"
#include "physics/random.hpp"

namespace cansim::personalities {

namespace {

// One overload per DeviceSettings alternative: std::visit fails to compile
// when a personality's settings have no maker.
struct Maker {
  const model::Profile& profile;
  const NodeContext& ctx;

  std::unique_ptr<Application> operator()(const model::GenericSettings&) const { return generic::make(profile, ctx); }
  std::unique_ptr<Application> operator()(const model::DpsSettings& s) const { return dps::make(profile, s, ctx); }
  std::unique_ptr<Application> operator()(const model::P92cSettings& s) const { return p92c::make(profile, s, ctx); }
  std::unique_ptr<Application> operator()(const model::GemsSettings& s) const { return gems9000::make(profile, s, ctx); }
  std::unique_ptr<Application> operator()(const model::SmcSettings& s) const { return smc::make(profile, s, ctx); }
  std::unique_ptr<Application> operator()(const model::CmpSettings& s) const { return cmp::make(profile, s, ctx); }
};

}  // namespace

std::unique_ptr<Application> make_application(const model::Profile& profile, const NodeContext& ctx) {
  return std::visit(Maker{profile, ctx}, profile.device);
}

MeasurementControl* measurement_control(Application* app) { return dynamic_cast<MeasurementControl*>(app); }

std::uint64_t node_seed(const NodeContext& ctx) {
  const std::uint64_t key = ctx.key.empty() ? ctx.index : physics::hash_string(ctx.key);
  return physics::derive_seed(ctx.fleet_seed, key);
}

std::unique_ptr<SensorSource> make_sensor_source(const model::Profile& profile, const NodeContext& ctx) {
  const model::PhysicsConfig& c = profile.physics;
  auto source = std::make_unique<SensorSource>(c.sensor, c.process, c.faults, node_seed(ctx));
  source->set_state_dir(ctx.state_dir);
  std::string error;
  if (!ctx.record_file.empty() && !source->record_to(ctx.record_file, &error))
    throw std::runtime_error(ctx.key + ": cannot record to " + ctx.record_file + ": " + error);
  return source;
}

}  // namespace cansim::personalities
