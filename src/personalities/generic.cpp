#include "personalities/generic.hpp"

namespace cansim::personalities::generic {

std::unique_ptr<Application> make(const model::Profile& profile, const NodeContext& ctx) {
  return std::make_unique<Cia404Application>(profile.cia404, make_sensor_source(profile, ctx), profile.identity,
                                             ctx.index);
}

}  // namespace cansim::personalities::generic
