#include "personalities/registry.hpp"

namespace cansim::personalities {

void prepare_profile(config::Profile& profile) {
  if (profile.personality != "generic")
    throw config::ConfigError(profile.file + ": personality: unknown personality '" + profile.personality +
                              "' (expected: generic)");
}

std::unique_ptr<Application> make_application(const config::Profile&, const NodeContext&) { return nullptr; }

}  // namespace cansim::personalities
