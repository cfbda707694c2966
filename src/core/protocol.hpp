// The protocol constants of CiA 301 and CiA 305, each named once: the
// predefined connection set and the bits of the COB-ID objects (cob), the NMT
// command specifiers and states, the EMCY codes of the CiA 301 services
// (emcy), the SDO protocol's byte 0 (sdo) and the LSS command specifiers (lss). Core, io, control, ctl and the
// personalities use these names; `scripts/layers --check` refuses a copy elsewhere in src/. Header only, no
// dependencies (ctl, the client, includes it too).
#pragma once

#include <cstdint>

namespace cansim {

// ---------------------------------------------------------------- CAN identifiers
// The predefined connection set (CiA 301 §7.3.5, with CiA 305 for LSS) and the
// bits of the COB-ID objects (0x1005, 0x1012, 0x1014, 0x1200, 0x14xx / 0x18xx:
// Tables 50, 53, 60, 71, 73).
namespace cob {

constexpr std::uint32_t kNmt = 0x000;
constexpr std::uint32_t kSync = 0x080;
constexpr std::uint32_t kEmcyBase = 0x080;  // + node-ID
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
constexpr std::uint32_t tpdo_default(unsigned n, std::uint8_t node_id) {
  return kTpdo1Base + 0x100 * (n - 1) + node_id;
}

// Flag on NodeService::collect_rx_ids() entries for 29-bit identifiers (as
// SocketCAN's CAN_EFF_FLAG).
constexpr std::uint32_t kRxIdExtended = 1u << 31;

constexpr std::uint32_t kId11Mask = 0x7FF;
constexpr std::uint32_t kId29Mask = 0x1FFFFFFF;

// The CAN-ID of a COB-ID object's value: bits 0-10, or 0-28 with bit 29 set.
constexpr std::uint32_t can_id(std::uint32_t cob_id) { return cob_id & (cob_id & kFrame29Bit ? kId29Mask : kId11Mask); }
// The CAN-ID with its frame format bit: what identifies the frame (bits 30
// and 31 aside).
constexpr std::uint32_t frame_id(std::uint32_t cob_id) { return cob_id & (kFrame29Bit | kId29Mask); }
// An 11-bit COB-ID has bits 11-28 clear (CiA 301 Tables 50, 53, 60, 71, 73).
constexpr bool format_ok(std::uint32_t cob_id) {
  return (cob_id & kFrame29Bit) || (cob_id & kId29Mask & ~kId11Mask) == 0;
}
// The collect_rx_ids() entry of a COB-ID.
constexpr std::uint32_t rx_id(std::uint32_t cob_id) {
  return cob_id & kFrame29Bit ? can_id(cob_id) | kRxIdExtended : can_id(cob_id);
}

// A CAN-ID of the connection set: function code (bits 10-7) + node-ID (bits 6-0).
constexpr std::uint32_t kNodeIdBits = 0x7F;
constexpr std::uint32_t function_code(std::uint32_t can_id) { return can_id & ~kNodeIdBits; }
constexpr std::uint8_t node_id_of(std::uint32_t can_id) { return std::uint8_t(can_id & kNodeIdBits); }

// CAN-IDs CiA 301 §7.3.5 (Table 3) reserves for other services: no PDO may use them.
constexpr bool restricted(std::uint32_t id) {
  return id == 0x000 || (id >= 0x001 && id <= 0x07F) || (id >= 0x101 && id <= 0x180) || (id >= 0x581 && id <= 0x5FF) ||
         (id >= 0x601 && id <= 0x67F) || (id >= 0x6E0 && id <= 0x6FF) || (id >= 0x701 && id <= 0x77F) ||
         (id >= 0x780 && id <= 0x7FF);
}

}  // namespace cob

// ---------------------------------------------------------------- NMT
// NMT states as the heartbeat byte encodes them (CiA 301 Table 58); bit 7 of
// a node guarding reply is the toggle bit.
enum class NmtState : std::uint8_t {
  kInitialising = 0x00,  // the boot-up frame's byte
  kStopped = 0x04,
  kOperational = 0x05,
  kPreOperational = 0x7F,
};
constexpr std::uint8_t kNmtStateBits = 0x7F;
constexpr std::uint8_t kGuardingToggle = 0x80;

// NMT command specifiers (CiA 301 §7.2.8.3.1), byte 0 of frame 0x000; byte 1
// is the node-ID, 0 for all nodes.
enum : std::uint8_t {
  kNmtStart = 0x01,
  kNmtStop = 0x02,
  kNmtEnterPreOperational = 0x80,
  kNmtResetNode = 0x81,
  kNmtResetCommunication = 0x82,
};
constexpr std::uint8_t kNmtAllNodes = 0x00;

// ---------------------------------------------------------------- EMCY
// The error codes the CiA 301 services send themselves (Table 21); a device's
// own codes are its personality's, their meanings its profile's `emcy:`.
namespace emcy {

enum : std::uint16_t {
  kErrorReset = 0x0000,            // error reset / no error
  kCanOverrun = 0x8110,            // CAN overrun (objects lost)
  kErrorPassive = 0x8120,          // CAN in error passive mode
  kLifeGuardOrHeartbeat = 0x8130,  // life guard error or heartbeat error
  kRecoveredFromBusOff = 0x8140,
  kPdoLength = 0x8210,  // PDO not processed due to length error
  kPdoLengthExceeded = 0x8220,
  kSyncLength = 0x8240,  // unexpected SYNC data length
  kRpdoTimeout = 0x8250,
};

}  // namespace emcy

// ---------------------------------------------------------------- SDO
// The SDO protocol's byte 0 (CiA 301 §7.2.4.3): command specifiers and the
// bits beside them, named as lely-core's src/co/sdo.h names them
// (CO_SDO_CCS_* / CO_SDO_SCS_*), so the server reads as the figures of the
// standard and never as bare numbers.
namespace sdo {

// Bits 7-5: the command specifier, unshifted (as lely: ccs / scs << 5).
constexpr std::uint8_t kCsMask = 0xE0;

// Client command specifiers (requests).
constexpr std::uint8_t kCcsDownloadSegment = 0x00;   // CO_SDO_CCS_DN_SEG_REQ
constexpr std::uint8_t kCcsInitiateDownload = 0x20;  // CO_SDO_CCS_DN_INI_REQ
constexpr std::uint8_t kCcsInitiateUpload = 0x40;    // CO_SDO_CCS_UP_INI_REQ
constexpr std::uint8_t kCcsUploadSegment = 0x60;     // CO_SDO_CCS_UP_SEG_REQ
constexpr std::uint8_t kCcsBlockUpload = 0xA0;       // CO_SDO_CCS_BLK_UP_REQ
constexpr std::uint8_t kCcsBlockDownload = 0xC0;     // CO_SDO_CCS_BLK_DN_REQ

// Server command specifiers (responses).
constexpr std::uint8_t kScsUploadSegment = 0x00;     // CO_SDO_SCS_UP_SEG_RES
constexpr std::uint8_t kScsDownloadSegment = 0x20;   // CO_SDO_SCS_DN_SEG_RES
constexpr std::uint8_t kScsInitiateUpload = 0x40;    // CO_SDO_SCS_UP_INI_RES
constexpr std::uint8_t kScsInitiateDownload = 0x60;  // CO_SDO_SCS_DN_INI_RES
constexpr std::uint8_t kScsBlockDownload = 0xA0;     // CO_SDO_SCS_BLK_DN_RES
constexpr std::uint8_t kScsBlockUpload = 0xC0;       // CO_SDO_SCS_BLK_UP_RES

// Abort transfer, either side (§7.2.4.3.17).
constexpr std::uint8_t kCsAbort = 0x80;  // CO_SDO_CS_ABORT

// Initiate (§7.2.4.3.3 / .6): e and s bits; n (bits 3-2) = bytes of the 4 that carry no data.
constexpr std::uint8_t kExpedited = 0x02;      // CO_SDO_INI_SIZE_EXP
constexpr std::uint8_t kSizeIndicated = 0x01;  // CO_SDO_INI_SIZE_IND
constexpr std::uint8_t expedited_unused(unsigned bytes) { return std::uint8_t((4 - bytes) << 2); }
constexpr unsigned expedited_bytes(std::uint8_t cs) { return 4u - ((cs >> 2) & 0x03u); }

// Segments (§7.2.4.3.4 / .7): toggle t, n (bits 3-1) = bytes of the 7 that carry no data, c = last.
constexpr std::uint8_t kToggle = 0x10;       // CO_SDO_SEG_TOGGLE
constexpr std::uint8_t kLastSegment = 0x01;  // CO_SDO_SEG_LAST
constexpr std::uint8_t segment_unused(unsigned bytes) { return std::uint8_t((7 - bytes) << 1); }
constexpr unsigned segment_bytes(std::uint8_t cs) { return 7u - ((cs >> 1) & 0x07u); }

// Block transfer (§7.2.4.3.9-16): cc / sc and s bits of the initiate, the
// sub-command in bits 1-0 (client block upload: 2 bits, block download: bit 0),
// and byte 0 of a sub-block segment (c | seqno).
constexpr std::uint8_t kBlockCrc = 0x04;            // CO_SDO_BLK_CRC
constexpr std::uint8_t kBlockSizeIndicated = 0x02;  // CO_SDO_BLK_SIZE_IND
constexpr std::uint8_t kScMask = 0x03;
constexpr std::uint8_t kScInitiate = 0x00;                 // CO_SDO_SC_INI_BLK
constexpr std::uint8_t kScEnd = 0x01;                      // CO_SDO_SC_END_BLK
constexpr std::uint8_t kScAck = 0x02;                      // CO_SDO_SC_BLK_RES
constexpr std::uint8_t kScStartUpload = 0x03;              // CO_SDO_SC_START_UP
constexpr std::uint8_t kBlockEndMask = kCsMask | kScMask;  // an end frame's n bits (4-2) aside
constexpr std::uint8_t block_end_unused(unsigned bytes) { return std::uint8_t(bytes << 2); }
constexpr unsigned block_end_unused_bytes(std::uint8_t cs) { return (cs >> 2) & 0x07u; }
constexpr std::uint8_t kSeqLast = 0x80;  // CO_SDO_SEQ_LAST
constexpr std::uint8_t kSeqMask = 0x7F;
constexpr std::uint8_t kMaxBlockSize = 127;  // 0 < blksize < 128

}  // namespace sdo

// ---------------------------------------------------------------- LSS
// CiA 305 v3.0.0: byte 0 of the 8-byte frames on cob::kLssFromMaster /
// kLssToMaster (Figs. 31-46); requests and replies share the specifiers.
namespace lss {

enum : std::uint8_t {
  kSwitchGlobal = 0x04,
  kConfigureNodeId = 0x11,
  kConfigureBitTiming = 0x13,
  kActivateBitTiming = 0x15,
  kStoreConfiguration = 0x17,
  kSelectiveVendor = 0x40,
  kSelectiveProduct = 0x41,
  kSelectiveRevision = 0x42,
  kSelectiveSerial = 0x43,
  kSelectiveReply = 0x44,
  kIdentifyVendor = 0x46,
  kIdentifyProduct = 0x47,
  kIdentifyRevisionLow = 0x48,
  kIdentifyRevisionHigh = 0x49,
  kIdentifySerialLow = 0x4A,
  kIdentifySerialHigh = 0x4B,
  kIdentifyNonConfigured = 0x4C,
  kIdentifySlaveReply = 0x4F,
  kNonConfiguredReply = 0x50,
  kFastscan = 0x51,
  kInquireVendor = 0x5A,
  kInquireProduct = 0x5B,
  kInquireRevision = 0x5C,
  kInquireSerial = 0x5D,
  kInquireNodeId = 0x5E,
};

// Byte 1 of the configure / store replies.
enum : std::uint8_t { kOk = 0, kOutOfRange = 1, kStoreFailed = 2, kManufacturer = 0xFF };

// Switch state global, byte 1.
enum : std::uint8_t { kModeWaiting = 0, kModeConfiguration = 1 };

constexpr std::uint8_t kFastscanConfirm = 0x80;     // fastscan BitChecked: reset and confirm presence
constexpr std::uint8_t kUnconfiguredNodeId = 0xFF;  // the node-ID of an LSS-unconfigured node

}  // namespace lss

}  // namespace cansim
