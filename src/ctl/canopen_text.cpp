#include "ctl/canopen_text.hpp"

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
    {0x01, "start"}, {0x02, "stop"}, {0x80, "preop"}, {0x81, "reset"}, {0x82, "reset-comm"},
};

constexpr Named<std::uint8_t> kNmtStates[] = {
    {0x00, "boot-up"}, {0x04, "stopped"}, {0x05, "operational"}, {0x7F, "pre-operational"},
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

// CiA 305 command specifiers (requests 0x7E5 and responses 0x7E4 share them).
constexpr Named<std::uint8_t> kLssCommands[] = {
    {0x04, "switch state global"},
    {0x11, "configure node-ID"},
    {0x13, "configure bit timing"},
    {0x15, "activate bit timing"},
    {0x17, "store configuration"},
    {0x40, "switch state selective: vendor-ID"},
    {0x41, "switch state selective: product code"},
    {0x42, "switch state selective: revision number"},
    {0x43, "switch state selective: serial number"},
    {0x44, "switch state selective: response"},
    {0x46, "identify remote slave: vendor-ID"},
    {0x47, "identify remote slave: product code"},
    {0x48, "identify remote slave: revision low"},
    {0x49, "identify remote slave: revision high"},
    {0x4A, "identify remote slave: serial low"},
    {0x4B, "identify remote slave: serial high"},
    {0x4C, "identify non-configured remote slave"},
    {0x4F, "identify slave"},
    {0x50, "identify non-configured slave"},
    {0x51, "fastscan"},
    {0x5A, "inquire vendor-ID"},
    {0x5B, "inquire product code"},
    {0x5C, "inquire revision number"},
    {0x5D, "inquire serial number"},
    {0x5E, "inquire node-ID"},
};

}  // namespace

std::string_view nmt_command_name(std::uint8_t cs) { return find(kNmtCommands, cs); }

std::string_view nmt_state_name(std::uint8_t state) { return find(kNmtStates, std::uint8_t(state & 0x7F)); }

std::string emcy_meaning(std::uint16_t code) {
  for (std::uint16_t key : {code, std::uint16_t(code & 0xFF00), std::uint16_t(code & 0xF000)}) {
    if (std::string_view name = find(kEmcyCodes, key); !name.empty()) return std::string(name);
  }
  return "unknown";
}

std::string_view sdo_abort_meaning(std::uint32_t code) { return find(kSdoAborts, code); }

std::string_view lss_command_name(std::uint8_t cs) { return find(kLssCommands, cs); }

}  // namespace cansim::ctl
