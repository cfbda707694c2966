#include "personalities/registry.hpp"

#include <variant>

#include "personalities/analog_output.hpp"
#include "personalities/cmp.hpp"
#include "personalities/dps.hpp"
#include "personalities/gems9000.hpp"
#include "personalities/generic.hpp"
#include "personalities/p92c.hpp"
#include "personalities/smc.hpp"

namespace cansim::personalities {

namespace {

// One overload per DeviceSettings alternative: std::visit fails to compile
// when a personality's settings have no application.
struct Maker {
  const model::Profile& profile;
  const NodeContext& ctx;

  template <class App>
  std::unique_ptr<Application> make(const typename App::DeviceSettings& s) const {
    return make_sensor_application<App>(profile, s, ctx);
  }
  auto operator()(const model::GenericSettings& s) const { return make<generic::GenericApplication>(s); }
  auto operator()(const model::DpsSettings& s) const { return make<dps::DpsApplication>(s); }
  auto operator()(const model::P92cSettings& s) const { return make<p92c::P92cApplication>(s); }
  auto operator()(const model::GemsSettings& s) const { return make<gems9000::GemsApplication>(s); }
  auto operator()(const model::SmcSettings& s) const { return make<smc::SmcApplication>(s); }
  auto operator()(const model::CmpSettings& s) const { return make<cmp::CmpApplication>(s); }
  // No CiA 404 chain: the actuator of a closed loop (analog_output.hpp).
  std::unique_ptr<Application> operator()(const model::AnalogOutputSettings& s) const {
    return analog_output::make(profile, s, ctx);
  }
};

}  // namespace

std::unique_ptr<Application> make_application(const model::Profile& profile, const NodeContext& ctx) {
  return std::visit(Maker{profile, ctx}, profile.device);
}

}  // namespace cansim::personalities
