// YAML -> the CiA 404 chain of a profile (`vendor: cia404:`): the chain
// settings and the channels, bound to the profile's layout. Without a
// `channels:` list every PV / field-value sub-index is a channel with the
// CiA 404 defaults. Errors name file:line:column: vendor.cia404.<key>.
#pragma once

#include <memory>

#include "config/yaml_util.hpp"
#include "model/cia404_profile.hpp"

namespace cansim::config {

std::shared_ptr<model::Cia404Profile> parse_cia404(const Where& w, const YAML::Node& section, OdLayout& layout);

}  // namespace cansim::config
