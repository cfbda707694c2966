// Per-profile node options: documented vendor deviations ("quirks") and
// service settings, chosen by profile data (`options:` in a profile YAML).
// Each option is named after what it does. The list is an X-macro so the
// profile loader validates keys and types without knowing the services.
//
// Add an option: one line X(type, name, default, "help"). Types: bool,
// int64_t, std::string.
#pragma once

#include <cstdint>
#include <string>

namespace cansim {

#define CANSIM_NODE_OPTIONS(X)                                                                    \
  /* NMT (CiA 301 §7.3.2) */                                                                     \
  X(bool, nmt_auto_start, false, "enter OPERATIONAL by itself after boot-up")                    \
  X(int64_t, nmt_auto_start_delay_ms, 0, "delay between boot-up and the autonomous start")      \
  X(int64_t, nmt_start_all_delay_ms, -1,                                                          \
    "send NMT 'start remote node' to all nodes this long after boot-up (-1: never)")              \
  X(int64_t, boot_up_delay_ms, 0, "time from power-on / reset to the boot-up frame")             \
  /* SDO server (CiA 301 §7.2.4) */                                                              \
  X(bool, sdo_expedited_only, false, "refuse segmented and block transfers")                     \
  X(bool, sdo_block_transfer, true, "support block upload / download")                           \
  X(bool, sdo_upload_size_indicated, true, "set the size bits in upload initiate responses")     \
  X(int64_t, sdo_timeout_ms, 1000, "abort a stalled segmented/block transfer with 0x05040000")  \
  /* EMCY (CiA 301 §7.2.7) */                                                                    \
  X(int64_t, emcy_history_bad_write_abort, 0x06090030,                                            \
    "abort code for writing a non-zero value to 0x1003:00")                                       \
  /* PDO (CiA 301 §7.2.2) */                                                                     \
  X(std::string, tpdo_allowed_types, "0-240,252-255",                                             \
    "TPDO transmission types accepted on 0x18xx:02 (ranges)")                                     \
  X(int64_t, tpdo_bad_type_abort, 0x06090030, "abort code for a refused transmission type")      \
  /* LSS (CiA 305) */                                                                            \
  X(bool, lss_supported, true, "answer LSS services on 0x7E5")                                   \
  X(bool, lss_only_in_stopped, false, "accept LSS configuration only in NMT STOPPED")            \
  X(bool, lss_revision_zero_wildcard, false, "revision 0 in switch-selective matches any")       \
  X(std::string, lss_bit_rates, "0-4,6-8", "CiA 305 table indices the node can run at")         \
  /* Heartbeat consumer / guarding */                                                             \
  X(int64_t, heartbeat_consumer_emcy, 0x8130, "EMCY code on heartbeat consumer timeout")

struct NodeOptions {
#define CANSIM_DECLARE_OPTION(type, name, def, help) type name = def;
  CANSIM_NODE_OPTIONS(CANSIM_DECLARE_OPTION)
#undef CANSIM_DECLARE_OPTION
};

// Parses a list of ranges "0-240,252,254-255" into a 256-bit set.
struct ByteSet {
  std::uint64_t bits[4] = {};
  bool has(std::uint8_t v) const { return (bits[v >> 6] >> (v & 63)) & 1; }
  void add(std::uint8_t v) { bits[v >> 6] |= std::uint64_t(1) << (v & 63); }
  static bool parse(const std::string& text, ByteSet& out);
};

}  // namespace cansim
