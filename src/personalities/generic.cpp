#include "personalities/generic.hpp"

#include "personalities/vendor_params.hpp"

namespace cansim::personalities::generic {

void prepare(config::Profile& profile, PreparedProfile&) { VendorParams(profile).reject_unknown_keys(); }

std::unique_ptr<Application> make(const config::Profile&, const PreparedProfile& prepared, const NodeContext& ctx) {
  return std::make_unique<Cia404Application>(prepared.cia404, make_sensor_source(prepared, ctx), prepared.identity,
                                             ctx.index);
}

}  // namespace cansim::personalities::generic
