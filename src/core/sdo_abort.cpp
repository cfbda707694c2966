#include "core/sdo_abort.hpp"

namespace cansim {

const char* describe(SdoAbort code) {
  switch (code) {
    case SdoAbort::kNone: return "no error";
    case SdoAbort::kToggleBit: return "toggle bit not alternated";
    case SdoAbort::kTimeout: return "SDO protocol timed out";
    case SdoAbort::kCommandSpecifier: return "client/server command specifier not valid or unknown";
    case SdoAbort::kBlockSize: return "invalid block size";
    case SdoAbort::kSequenceNumber: return "invalid sequence number";
    case SdoAbort::kCrc: return "CRC error";
    case SdoAbort::kOutOfMemory: return "out of memory";
    case SdoAbort::kUnsupportedAccess: return "unsupported access to an object";
    case SdoAbort::kWriteOnly: return "attempt to read a write-only object";
    case SdoAbort::kReadOnly: return "attempt to write a read-only object";
    case SdoAbort::kNoObject: return "object does not exist in the object dictionary";
    case SdoAbort::kNotMappable: return "object cannot be mapped to the PDO";
    case SdoAbort::kPdoLength: return "number and length of objects to be mapped exceed PDO length";
    case SdoAbort::kParamIncompatible: return "general parameter incompatibility";
    case SdoAbort::kInternalIncompatible: return "general internal incompatibility in the device";
    case SdoAbort::kHardware: return "access failed due to a hardware error";
    case SdoAbort::kTypeMismatch: return "data type does not match, length of service parameter does not match";
    case SdoAbort::kLengthTooHigh: return "data type does not match, length of service parameter too high";
    case SdoAbort::kLengthTooLow: return "data type does not match, length of service parameter too low";
    case SdoAbort::kNoSubIndex: return "sub-index does not exist";
    case SdoAbort::kInvalidValue: return "invalid value for parameter";
    case SdoAbort::kValueTooHigh: return "value of parameter written too high";
    case SdoAbort::kValueTooLow: return "value of parameter written too low";
    case SdoAbort::kMaxLessThanMin: return "maximum value is less than minimum value";
    case SdoAbort::kNoResource: return "resource not available: SDO connection";
    case SdoAbort::kGeneral: return "general error";
    case SdoAbort::kDataTransfer: return "data cannot be transferred or stored to the application";
    case SdoAbort::kLocalControl: return "data cannot be transferred or stored because of local control";
    case SdoAbort::kDeviceState: return "data cannot be transferred or stored because of the present device state";
    case SdoAbort::kNoOd: return "object dictionary dynamic generation fails or no object dictionary is present";
    case SdoAbort::kNoData: return "no data available";
  }
  return "unknown abort code";
}

}  // namespace cansim
