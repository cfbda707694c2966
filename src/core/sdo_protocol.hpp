// The SDO protocol's byte 0 (CiA 301 §7.2.4.3): command specifiers and the
// bits beside them, named as lely-core's src/co/sdo.h names them
// (CO_SDO_CCS_* / CO_SDO_SCS_*), so the server reads as the figures of the
// standard and never as bare numbers.
#pragma once

#include <cstdint>

namespace cansim::sdo {

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
constexpr std::uint8_t kToggle = 0x10;     // CO_SDO_SEG_TOGGLE
constexpr std::uint8_t kLastSegment = 0x01;  // CO_SDO_SEG_LAST
constexpr std::uint8_t segment_unused(unsigned bytes) { return std::uint8_t((7 - bytes) << 1); }
constexpr unsigned segment_bytes(std::uint8_t cs) { return 7u - ((cs >> 1) & 0x07u); }

// Block transfer (§7.2.4.3.9-16): cc / sc and s bits of the initiate, the
// sub-command in bits 1-0 (client block upload: 2 bits, block download: bit 0),
// and byte 0 of a sub-block segment (c | seqno).
constexpr std::uint8_t kBlockCrc = 0x04;            // CO_SDO_BLK_CRC
constexpr std::uint8_t kBlockSizeIndicated = 0x02;  // CO_SDO_BLK_SIZE_IND
constexpr std::uint8_t kScMask = 0x03;
constexpr std::uint8_t kScInitiate = 0x00;          // CO_SDO_SC_INI_BLK
constexpr std::uint8_t kScEnd = 0x01;               // CO_SDO_SC_END_BLK
constexpr std::uint8_t kScAck = 0x02;               // CO_SDO_SC_BLK_RES
constexpr std::uint8_t kScStartUpload = 0x03;       // CO_SDO_SC_START_UP
constexpr std::uint8_t kBlockEndMask = kCsMask | kScMask;  // an end frame's n bits (4-2) aside
constexpr std::uint8_t block_end_unused(unsigned bytes) { return std::uint8_t(bytes << 2); }
constexpr unsigned block_end_unused_bytes(std::uint8_t cs) { return (cs >> 2) & 0x07u; }
constexpr std::uint8_t kSeqLast = 0x80;   // CO_SDO_SEQ_LAST
constexpr std::uint8_t kSeqMask = 0x7F;
constexpr std::uint8_t kMaxBlockSize = 127;  // 0 < blksize < 128

}  // namespace cansim::sdo
