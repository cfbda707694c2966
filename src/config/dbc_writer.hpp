// A Vector DBC file describing one CAN bus of a fleet, so the simulated
// sensors decode in the tools bench engineers already have (cantools,
// SavvyCAN, CANoe, Wireshark with a DBC, python3-canmatrix): per node its
// valid TPDOs and RPDOs (one signal per mapped object: start bit, length,
// little-endian byte order, signedness, IEEE float, the factor of a CiA 404
// integer view (10^-digits) and the channel's unit, the value range of the
// type or of the object's limits), its heartbeat / boot-up and EMCY; the bus's
// NMT and SYNC. What a node's PDOs carry comes from personalities::pdo_views
// of the node at power-on, the same view the control API's GetPdoMapping gives.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "personalities/pdo_view.hpp"

namespace cansim::config {

struct DbcNode {
  std::string label;    // as people name it: "generic/0", "dps"
  std::string key;      // fleet key
  std::string profile;  // profile name
  std::uint8_t node_id = 1;
  std::vector<personalities::PdoView> pdos;
  // Every EMCY code the node may send and what it means (the EMCY message's
  // value table): the profile's `emcy:` and its CiA 301 services' codes.
  std::map<std::uint16_t, std::string> emcy_codes;
};

struct DbcBus {
  std::string name;  // "vcan0"
  std::uint32_t bit_rate_kbit = 250;
  std::vector<DbcNode> nodes;
};

std::string write_dbc(const DbcBus& bus);

// A DBC identifier ([A-Za-z_][A-Za-z0-9_]*) for a name: other characters
// become '_', runs of '_' one, a leading digit gets "n".
std::string dbc_identifier(const std::string& name);

}  // namespace cansim::config
