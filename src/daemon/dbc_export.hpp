// cansimd --export-dbc: the DBC of one bus of a fleet (config/dbc_writer.hpp),
// each node built as the daemon builds it and powered on, so its PDOs are
// described as they are configured at power-on (profile defaults, no stored
// parameters).
#pragma once

#include <string>

#include "config/fleet.hpp"

namespace cansim::daemon {

// `interface` "" : the fleet's only interface. Throws config::ConfigError
// when the fleet has several and none is named, or no such interface.
std::string export_dbc(const config::FleetConfig& fleet, const std::string& interface);

}  // namespace cansim::daemon
