#include "personalities/generic.hpp"

namespace cansim::personalities::generic {

std::unique_ptr<Application> make(const model::Profile& profile, const NodeContext& ctx) {
  auto app = std::make_unique<Cia404Application>(profile.cia404, make_sensor_source(profile, ctx), profile.identity,
                                                 ctx.index);
  app->set_sensor_fault_emcy(true);
  return app;
}

}  // namespace cansim::personalities::generic
