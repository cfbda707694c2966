// Resolves how a client names a node (docs/control-api.md, "Node names"):
// the fleet key "vcan0/dps/0", the entry name "dps", "name/INDEX", or
// "IFACE/ID" with the node's current node-ID ("vcan0/5", "vcan0/0x10").
#pragma once

#include <string>

#include "control/control_host.hpp"

namespace cansim::control {

// The node, or nullptr with *why set ("no node 'x'", "'gen' names 3 nodes: ...").
const NodeHandle* resolve_node(ControlHost& host, const std::string& spec, std::string* why);

}  // namespace cansim::control
