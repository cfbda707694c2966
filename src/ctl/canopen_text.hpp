// CANopen protocol values by name, as the bus monitor prints them: NMT
// commands and states (CiA 301 §7.2.8.3), EMCY error codes (CiA 301 Table 21,
// CiA 404 §7.3), SDO abort codes (CiA 301 Table 22), LSS command specifiers
// (CiA 305 §6). Written from the specifications, not from the daemon's
// tables: the monitor is a second reading of the same frames.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace cansim::ctl {

// "start", "stop", "pre-operational", "reset-node", "reset-communication"
// (cansimctl nmt's words, CiA 301's names); "" for others.
std::string_view nmt_command_name(std::uint8_t cs);
// Heartbeat / guarding state (toggle bit masked): "pre-operational", ...; "" for others.
std::string_view nmt_state_name(std::uint8_t state);
// The most specific meaning CiA 301 / CiA 404 give the code ("current, device input side").
std::string emcy_meaning(std::uint16_t code);
std::string_view sdo_abort_meaning(std::uint32_t code);  // "" when unknown
std::string_view lss_command_name(std::uint8_t cs);      // "" when unknown
// Objects CiA 301 / 404 write in hex: identifiers, COB-IDs, PDO mappings,
// error codes and registers, signatures, unit codes, status bits (0x1000,
// 0x1001-0x1003, 0x1005, 0x1010-0x1012, 0x1014, 0x1016, 0x1018:01-03,
// 0x1200-0x12FF:01-03, 0x14xx:01, 0x16xx, 0x18xx:01, 0x1Axx, 0x1F80, 0x6131,
// 0x6150); their sub 0 (a count) is decimal.
bool written_in_hex(std::uint16_t index, std::uint8_t sub);

}  // namespace cansim::ctl
