// YAML -> a personality's typed settings: the keys of a profile's `vendor:`
// section besides `cia404` (config/cia404_yaml.hpp), each named once, in one
// overload per personality. Errors name file:line:column: vendor.<key>.
#pragma once

#include "config/vendor_params.hpp"
#include "model/profile.hpp"

namespace cansim::config {

// `serial_number_base`, shared by every personality.
model::IdentitySettings parse_identity(const VendorParams& v);

// Fills the alternative `profile.device` already holds (the personality's)
// from `v`; reads profile.layout / options / physics where a setting
// depends on them. Rejects keys no personality setting reads.
void parse_device_settings(const VendorParams& v, model::Profile& profile);

}  // namespace cansim::config
