#include "personalities/node_context.hpp"

#include <stdexcept>

#include "physics/random.hpp"

namespace cansim::personalities {

std::uint64_t node_seed(const NodeContext& ctx) {
  const std::uint64_t key = ctx.key.empty() ? ctx.index : physics::hash_string(ctx.key);
  return physics::derive_seed(ctx.fleet_seed, key);
}

std::unique_ptr<SensorSource> make_sensor_source(const model::Profile& profile, const NodeContext& ctx) {
  const model::PhysicsConfig& c = profile.physics;
  std::unique_ptr<SensorSource> source;
  try {
    source = std::make_unique<SensorSource>(c.sensor, c.process, c.faults, node_seed(ctx), ctx.plants);
  } catch (const std::invalid_argument& e) {  // a plant term that does not resolve
    throw std::runtime_error(ctx.key + ": " + e.what());
  }
  source->set_state_dir(ctx.state_dir);
  std::string error;
  if (!ctx.record_file.empty() && !source->record_to(ctx.record_file, &error))
    throw std::runtime_error(ctx.key + ": cannot record to " + ctx.record_file + ": " + error);
  return source;
}

}  // namespace cansim::personalities
