// Personality registry: turns a typed profile (model::Profile, its `device`
// settings naming the behaviour) into the Application that gives each node
// its vendor behaviour and measurements. Profiles come from a loader
// (config/), which checked them against personalities/catalog.hpp. The
// registry includes every vendor; no vendor includes it (node_context.hpp
// has what they share).
#pragma once

#include <memory>

#include "core/application.hpp"
#include "model/profile.hpp"
#include "personalities/catalog.hpp"
#include "personalities/cia404.hpp"
#include "personalities/measurement_control.hpp"
#include "personalities/node_context.hpp"

namespace cansim::personalities {

// One Application per node, by the profile's device settings.
std::unique_ptr<Application> make_application(const model::Profile& profile, const NodeContext& ctx);

}  // namespace cansim::personalities
