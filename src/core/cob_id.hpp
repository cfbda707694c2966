// CAN identifiers of CiA 301: the predefined connection set (§7.3.5, with
// CiA 305 for LSS) and the bits of the COB-ID objects (0x1005, 0x1012,
// 0x1014, 0x1200, 0x14xx / 0x18xx: Tables 50, 53, 60, 71, 73).
#pragma once

#include <cstdint>

namespace cansim::cob {

constexpr std::uint32_t kNmt = 0x000;
constexpr std::uint32_t kSync = 0x080;
constexpr std::uint32_t kEmcyBase = 0x080;          // + node-ID
constexpr std::uint32_t kSdoTxBase = 0x580;         // server -> client, + node-ID
constexpr std::uint32_t kSdoRxBase = 0x600;         // client -> server, + node-ID
constexpr std::uint32_t kErrorControlBase = 0x700;  // boot-up, heartbeat, node guarding, + node-ID
constexpr std::uint32_t kLssToMaster = 0x7E4;       // CiA 305
constexpr std::uint32_t kLssFromMaster = 0x7E5;

// Bits of a COB-ID object (bit 30 means something else in each: no RTR for a
// TPDO, generate for SYNC, reserved for EMCY).
constexpr std::uint32_t kInvalid = 1u << 31;
constexpr std::uint32_t kFrame29Bit = 1u << 29;

// Flag on NodeService::collect_rx_ids() entries for 29-bit identifiers (as
// SocketCAN's CAN_EFF_FLAG).
constexpr std::uint32_t kRxIdExtended = 1u << 31;

}  // namespace cansim::cob
