// Which nodes a NODE argument names. The acting verbs (set, override, fault,
// cancel, power-cycle, nmt) take a group too: a glob of keys or names
// ('generic/*', 'vcan1/*'), an ID range (vcan0/0x10-0x13) or the name of a
// count: group (generic); anything else is one node, which the daemon
// resolves (Fleet1.GetNode: a key, a name, IFACE/ID).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ctl/replies.hpp"

namespace cansim::ctl {

// The nodes of `rows` (ListNodes) a group names, in natural order of their
// keys (empty: it names none); nullopt when `spec` is no group.
std::optional<std::vector<NodeRow>> group_targets(const std::string& spec, const std::vector<NodeRow>& rows);

}  // namespace cansim::ctl
