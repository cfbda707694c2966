// `generic` personality: the plain CiA 404 chain for the channels of the
// profile (generic-404.yaml: ch1 pressure in bar, ch2 temperature in degC),
// measuring the profile's physics. A device personality has a make() like
// this one and usually a Cia404Application subclass with a few overrides.
#pragma once

#include <memory>

#include "personalities/registry.hpp"

namespace cansim::personalities::generic {

std::unique_ptr<Application> make(const model::Profile& profile, const NodeContext& ctx);

}  // namespace cansim::personalities::generic
