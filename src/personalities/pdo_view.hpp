// What a node's PDOs carry, in engineering terms: each PDO as the engine runs
// it now (CAN-ID, validity, transmission type, resolved mapping) and each
// mapped object with its name, type and meaning (unit and scale of a CiA 404
// valued object, Cia404Chain::entry_scale). Shared by the control API
// (GetPdoMapping, ListObjects: the decoded bus monitor) and the DBC export.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/node.hpp"

namespace cansim::personalities {

// What a raw value of an object means: engineering value = raw x scale + offset, in unit.
struct ObjectMeaning {
  double scale = 1.0;  // engineering value = raw x scale + offset, in `unit`
  double offset = 0.0;
  std::string unit;     // "bar", "degC", ...; "" for none
  bool counts = false;  // the device's own value is raw x count_scale counts (Cia404Chain::count_scaling)
  double count_scale = 1.0;
};

ObjectMeaning object_meaning(Node& node, const OdEntry& e);

struct PdoEntryView {
  std::uint16_t index = 0;  // of a dummy entry: 0
  std::uint8_t sub = 0;
  std::uint8_t bits = 0;           // mapped length
  const OdEntry* entry = nullptr;  // null for a dummy entry (CiA 301 §7.4.7.1)
  ObjectMeaning meaning;
};

struct PdoView {
  bool transmit = true;      // TPDO (the node sends it) or RPDO (it receives it)
  unsigned number = 1;       // 1-based: TPDO1 is 0x1800 / 0x1A00
  std::uint32_t can_id = 0;  // COB-ID bits 0-28 (11-bit unless extended)
  bool extended = false;     // COB-ID bit 29: 29-bit CAN-ID
  bool valid = false;        // the PDO exists (COB-ID bit 31 clear, or the vendor ignores it)
  std::uint8_t transmission_type = 0;
  std::uint8_t bits = 0;              // total mapped length
  std::vector<PdoEntryView> entries;  // empty when the mapping is empty or invalid

  std::string name() const { return (transmit ? "TPDO" : "RPDO") + std::to_string(number); }
};

// Every PDO of the node's profile, TPDOs first, each kind by number.
std::vector<PdoView> pdo_views(Node& node);

}  // namespace cansim::personalities
