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

// "start", "stop", "preop", "reset", "reset-comm" (cansimctl nmt's words); "" for others.
std::string_view nmt_command_name(std::uint8_t cs);
// Heartbeat / guarding state (toggle bit masked): "pre-operational", ...; "" for others.
std::string_view nmt_state_name(std::uint8_t state);
// The most specific meaning CiA 301 / CiA 404 give the code ("current, device input side").
std::string emcy_meaning(std::uint16_t code);
std::string_view sdo_abort_meaning(std::uint32_t code);  // "" when unknown
std::string_view lss_command_name(std::uint8_t cs);      // "" when unknown

}  // namespace cansim::ctl
