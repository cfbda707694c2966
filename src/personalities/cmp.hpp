// `trafag-cmp` personality: Trafag CMP 8270/8826 miniature pressure
// transmitter (manual V2.0, profiles/cmp.yaml, docs/devices/cmp.md).
//
// On top of the CiA 404 chain: predefined mapping modes (0x2100, mirrored
// read-only into 0x1A0x), a per-PDO EventMask routing delta / threshold events
// to TPDO types 0 and 254, special messages chosen by the last limit event,
// the type-254 timer that repeats only beyond a threshold, the ms counter of
// mapping mode 37, Auto-Start with AUTO-PRE-OPERATIONAL fault handling, the
// NMT start indication 250 ms after OPERATIONAL, the 0x2001 baud-rate object
// and the permanent self-test EMCYs.
#pragma once

#include <memory>

#include "personalities/registry.hpp"

namespace cansim::personalities::cmp {

std::unique_ptr<Application> make(const model::Profile& profile, const model::CmpSettings& settings,
                                  const NodeContext& ctx);

}  // namespace cansim::personalities::cmp
