#include "ctl/canopen_text.hpp"

#include "core/protocol.hpp"

namespace cansim::ctl {

namespace {

template <typename Key>
struct Named {
  Key key;
  std::string_view name;
};

template <typename Key, std::size_t N>
std::string_view find(const Named<Key> (&table)[N], Key key) {
  for (const auto& n : table) {
    if (n.key == key) return n.name;
  }
  return {};
}

constexpr Named<std::uint8_t> kNmtCommands[] = {
    {kNmtStart, "start"},
    {kNmtStop, "stop"},
    {kNmtEnterPreOperational, "pre-operational"},
    {kNmtResetNode, "reset-node"},
    {kNmtResetCommunication, "reset-communication"},
};

constexpr Named<std::uint8_t> kNmtStates[] = {
    {std::uint8_t(NmtState::kInitialising), "boot-up"},
    {std::uint8_t(NmtState::kStopped), "stopped"},
    {std::uint8_t(NmtState::kOperational), "operational"},
    {std::uint8_t(NmtState::kPreOperational), "pre-operational"},
};

// CiA 301 Table 21; the most specific entry wins (exact, then xx00, then x000).
constexpr Named<std::uint16_t> kEmcyCodes[] = {
    {0x0000, "error reset / no error"},
    {0x1000, "generic error"},
    {0x2000, "current"},
    {0x2100, "current, device input side"},
    {0x2200, "current inside the device"},
    {0x2300, "current, device output side"},
    {0x3000, "voltage"},
    {0x3100, "mains voltage"},
    {0x3200, "voltage inside the device"},
    {0x3300, "output voltage"},
    {0x4000, "temperature"},
    {0x4100, "ambient temperature"},
    {0x4200, "device temperature"},
    {0x5000, "device hardware"},
    {0x6000, "device software"},
    {0x6100, "internal software"},
    {0x6200, "user software"},
    {0x6300, "data set"},
    {0x7000, "additional modules"},
    {0x8000, "monitoring"},
    {0x8100, "communication"},
    {0x8110, "CAN overrun (objects lost)"},
    {0x8120, "CAN in error passive mode"},
    {0x8130, "life guard or heartbeat error"},
    {0x8140, "recovered from bus off"},
    {0x8150, "CAN-ID collision"},
    {0x8200, "protocol error"},
    {0x8210, "PDO not processed due to length error"},
    {0x8220, "PDO length exceeded"},
    {0x8230, "DAM MPDO not processed, destination object not available"},
    {0x8240, "unexpected SYNC data length"},
    {0x8250, "RPDO timeout"},
    {0x9000, "external error"},
    {0xF000, "additional functions"},
    {0xFF00, "device specific"},
};

constexpr Named<std::uint32_t> kSdoAborts[] = {
    {0x05030000, "toggle bit not alternated"},
    {0x05040000, "SDO protocol timed out"},
    {0x05040001, "command specifier not valid or unknown"},
    {0x05040002, "invalid block size"},
    {0x05040003, "invalid sequence number"},
    {0x05040004, "CRC error"},
    {0x05040005, "out of memory"},
    {0x06010000, "unsupported access to an object"},
    {0x06010001, "attempt to read a write-only object"},
    {0x06010002, "attempt to write a read-only object"},
    {0x06020000, "object does not exist"},
    {0x06040041, "object cannot be mapped to the PDO"},
    {0x06040042, "PDO length exceeded"},
    {0x06040043, "general parameter incompatibility"},
    {0x06040047, "general internal incompatibility in the device"},
    {0x06060000, "access failed due to a hardware error"},
    {0x06070010, "data type does not match, length of service parameter does not match"},
    {0x06070012, "data type does not match, length of service parameter too high"},
    {0x06070013, "data type does not match, length of service parameter too low"},
    {0x06090011, "sub-index does not exist"},
    {0x06090030, "invalid value for parameter"},
    {0x06090031, "value of parameter written too high"},
    {0x06090032, "value of parameter written too low"},
    {0x06090036, "maximum value is less than minimum value"},
    {0x060A0023, "resource not available: SDO connection"},
    {0x08000000, "general error"},
    {0x08000020, "data cannot be transferred or stored to the application"},
    {0x08000021, "data cannot be transferred or stored: local control"},
    {0x08000022, "data cannot be transferred or stored: present device state"},
    {0x08000023, "object dictionary not present"},
    {0x08000024, "no data available"},
};

// CiA 305 command specifiers (requests and responses share them).
constexpr Named<std::uint8_t> kLssCommands[] = {
    {lss::kSwitchGlobal, "switch state global"},
    {lss::kConfigureNodeId, "configure node-ID"},
    {lss::kConfigureBitTiming, "configure bit timing"},
    {lss::kActivateBitTiming, "activate bit timing"},
    {lss::kStoreConfiguration, "store configuration"},
    {lss::kSelectiveVendor, "switch state selective: vendor-ID"},
    {lss::kSelectiveProduct, "switch state selective: product code"},
    {lss::kSelectiveRevision, "switch state selective: revision number"},
    {lss::kSelectiveSerial, "switch state selective: serial number"},
    {lss::kSelectiveReply, "switch state selective: response"},
    {lss::kIdentifyVendor, "identify remote slave: vendor-ID"},
    {lss::kIdentifyProduct, "identify remote slave: product code"},
    {lss::kIdentifyRevisionLow, "identify remote slave: revision low"},
    {lss::kIdentifyRevisionHigh, "identify remote slave: revision high"},
    {lss::kIdentifySerialLow, "identify remote slave: serial low"},
    {lss::kIdentifySerialHigh, "identify remote slave: serial high"},
    {lss::kIdentifyNonConfigured, "identify non-configured remote slave"},
    {lss::kIdentifySlaveReply, "identify slave"},
    {lss::kNonConfiguredReply, "identify non-configured slave"},
    {lss::kFastscan, "fastscan"},
    {lss::kInquireVendor, "inquire vendor-ID"},
    {lss::kInquireProduct, "inquire product code"},
    {lss::kInquireRevision, "inquire revision number"},
    {lss::kInquireSerial, "inquire serial number"},
    {lss::kInquireNodeId, "inquire node-ID"},
};

}  // namespace

std::string_view nmt_command_name(std::uint8_t cs) { return find(kNmtCommands, cs); }

std::string_view nmt_state_name(std::uint8_t state) { return find(kNmtStates, std::uint8_t(state & kNmtStateBits)); }

std::string emcy_meaning(std::uint16_t code) {
  for (std::uint16_t key : {code, std::uint16_t(code & 0xFF00), std::uint16_t(code & 0xF000)}) {
    if (std::string_view name = find(kEmcyCodes, key); !name.empty()) return std::string(name);
  }
  return "unknown";
}

std::string_view sdo_abort_meaning(std::uint32_t code) { return find(kSdoAborts, code); }

std::string_view lss_command_name(std::uint8_t cs) { return find(kLssCommands, cs); }

bool written_in_hex(std::uint16_t index, std::uint8_t sub) {
  auto in = [index](unsigned first, unsigned last) { return index >= first && index <= last; };
  if (index == 0x1000 || index == 0x1001 || index == 0x1002 || index == 0x1005 || index == 0x1012 || index == 0x1014 ||
      index == 0x1F80)
    return true;
  if (sub == 0) return false;  // the count of an array or record
  if (index == 0x1003 || index == 0x1010 || index == 0x1011 || index == 0x1016 || index == 0x6131 || index == 0x6150)
    return true;
  if (index == 0x1018) return sub <= 3;     // vendor-ID, product code, revision; the serial is a number
  if (in(0x1200, 0x12FF)) return sub <= 3;  // SDO COB-IDs and the node-ID
  if (in(0x1400, 0x15FF) || in(0x1800, 0x19FF)) return sub == 1;  // PDO COB-IDs
  return in(0x1600, 0x17FF) || in(0x1A00, 0x1BFF);                // mapping entries
}

}  // namespace cansim::ctl
