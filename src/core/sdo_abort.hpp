// SDO abort codes (CiA 301 v4.2 §7.2.4.3.17, Table 22). Object dictionary access
// results are these codes, so an OD refusal maps 1:1 to what the SDO server sends.
#pragma once

#include <cstdint>

namespace cansim {

enum class SdoAbort : std::uint32_t {
  kNone = 0,
  kToggleBit = 0x05030000,
  kTimeout = 0x05040000,
  kCommandSpecifier = 0x05040001,
  kBlockSize = 0x05040002,
  kSequenceNumber = 0x05040003,
  kCrc = 0x05040004,
  kOutOfMemory = 0x05040005,
  kUnsupportedAccess = 0x06010000,
  kWriteOnly = 0x06010001,  // attempt to read a write-only object
  kReadOnly = 0x06010002,   // attempt to write a read-only object
  kNoObject = 0x06020000,
  kNotMappable = 0x06040041,
  kPdoLength = 0x06040042,
  kParamIncompatible = 0x06040043,
  kInternalIncompatible = 0x06040047,
  kHardware = 0x06060000,
  kTypeMismatch = 0x06070010,
  kLengthTooHigh = 0x06070012,
  kLengthTooLow = 0x06070013,
  kNoSubIndex = 0x06090011,
  kInvalidValue = 0x06090030,
  kValueTooHigh = 0x06090031,
  kValueTooLow = 0x06090032,
  kMaxLessThanMin = 0x06090036,
  kNoResource = 0x060A0023,
  kGeneral = 0x08000000,
  kDataTransfer = 0x08000020,
  kLocalControl = 0x08000021,
  kDeviceState = 0x08000022,
  kNoOd = 0x08000023,
  kNoData = 0x08000024,
};

inline bool ok(SdoAbort a) { return a == SdoAbort::kNone; }
const char* describe(SdoAbort code);

}  // namespace cansim
