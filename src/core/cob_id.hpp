// CAN identifiers of CiA 301: the predefined connection set (§7.3.5, with
// CiA 305 for LSS) and the bits of the COB-ID objects (0x1005, 0x1012,
// 0x1014, 0x1200, 0x14xx / 0x18xx: Tables 50, 53, 60, 71, 73).
#pragma once

#include <cstdint>

namespace cansim::cob {

constexpr std::uint32_t kNmt = 0x000;
constexpr std::uint32_t kSync = 0x080;
constexpr std::uint32_t kEmcyBase = 0x080;          // + node-ID
constexpr std::uint32_t kTime = 0x100;
constexpr std::uint32_t kTpdo1Base = 0x180;         // TPDO n: + 0x100 * (n - 1) + node-ID (n = 1..4)
constexpr std::uint32_t kRpdo1Base = 0x200;         // RPDO n: likewise
constexpr std::uint32_t kSdoTxBase = 0x580;         // server -> client, + node-ID
constexpr std::uint32_t kSdoRxBase = 0x600;         // client -> server, + node-ID
constexpr std::uint32_t kErrorControlBase = 0x700;  // boot-up, heartbeat, node guarding, + node-ID
constexpr std::uint32_t kLssToMaster = 0x7E4;       // CiA 305
constexpr std::uint32_t kLssFromMaster = 0x7E5;

// Bits of a COB-ID object (bit 30 means something else in each: no RTR for a
// TPDO, generate for SYNC, reserved for EMCY).
constexpr std::uint32_t kInvalid = 1u << 31;
constexpr std::uint32_t kNoRtr = 1u << 30;         // TPDO (Table 73)
constexpr std::uint32_t kGenerate = 1u << 30;      // SYNC 0x1005 (Table 50)
constexpr std::uint32_t kEmcyReserved = 1u << 30;  // EMCY 0x1014 (Table 60)
constexpr std::uint32_t kFrame29Bit = 1u << 29;

// The default COB-ID of TPDO n (1..4) of a node (the predefined connection set).
constexpr std::uint32_t tpdo_default(unsigned n, std::uint8_t node_id) { return kTpdo1Base + 0x100 * (n - 1) + node_id; }

// Flag on NodeService::collect_rx_ids() entries for 29-bit identifiers (as
// SocketCAN's CAN_EFF_FLAG).
constexpr std::uint32_t kRxIdExtended = 1u << 31;

constexpr std::uint32_t kId11Mask = 0x7FF;
constexpr std::uint32_t kId29Mask = 0x1FFFFFFF;

// The CAN-ID of a COB-ID object's value: bits 0-10, or 0-28 with bit 29 set.
constexpr std::uint32_t can_id(std::uint32_t cob_id) {
  return cob_id & (cob_id & kFrame29Bit ? kId29Mask : kId11Mask);
}
// The CAN-ID with its frame format bit: what identifies the frame (bits 30
// and 31 aside).
constexpr std::uint32_t frame_id(std::uint32_t cob_id) { return cob_id & (kFrame29Bit | kId29Mask); }
// An 11-bit COB-ID has bits 11-28 clear (CiA 301 Tables 50, 53, 60, 71, 73).
constexpr bool format_ok(std::uint32_t cob_id) { return (cob_id & kFrame29Bit) || (cob_id & kId29Mask & ~kId11Mask) == 0; }
// The collect_rx_ids() entry of a COB-ID.
constexpr std::uint32_t rx_id(std::uint32_t cob_id) {
  return cob_id & kFrame29Bit ? can_id(cob_id) | kRxIdExtended : can_id(cob_id);
}

}  // namespace cansim::cob
