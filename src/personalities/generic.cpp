#include "personalities/generic.hpp"

namespace cansim::personalities::generic {

void prepare(config::Profile& profile, PreparedProfile&) { check_vendor_keys(profile, {}); }

std::unique_ptr<Application> make(const config::Profile&, const PreparedProfile& prepared, const NodeContext& ctx) {
  return std::make_unique<Cia404Application>(prepared.cia404, make_sensor_source(prepared, ctx), prepared.identity,
                                             ctx.index);
}

}  // namespace cansim::personalities::generic
