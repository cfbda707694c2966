// Per-profile node options: documented vendor deviations ("quirks") and
// service settings, chosen by profile data (`options:` in a profile YAML).
// Each option is named after what it does. The list is an X-macro so the
// profile loader validates keys and values without knowing the services.
//
// Add an option: one line X(KIND, name, default, strict, "help"). The kind is
// declared once and the loader parses it (a value outside it fails --check
// with file:line:column and what was expected); services read typed values
// and have no fallback of their own:
//   BOOL            true / false
//   INT(lo, hi)     an integer in lo..hi
//   ENUM(Type)      one of the names of EnumNames<Type> ("on_reset", ...)
//   BYTES           a set of values 0..255 as ranges "0-240,252,254-255"
//   RANGES(max)     ranges of values 0..max, "" = every value
//   ABORTS          vendor abort codes "from=to,..." (SDO abort mapping)
// Defaults of ENUM, BYTES, RANGES and ABORTS are written as a profile would.
// The strict column says what strict mode (docs/profiles.md "Strict mode and quirks")
// does with it:
//   CIA(v)   a vendor deviation: CiA 301 / 305 prescribe v, and strict mode
//            sets v (a profile that sets anything else lists the option with
//            its manual reference under `quirks:`);
//   SETTING  a conformant choice (an optional service, a supported subset, a
//            timing, a vendor object): strict mode keeps the profile's value.
#pragma once

#include <array>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

namespace cansim {

// ---- the value types of the options that are not numbers

// What an EMCY says when one error clears and others stay active.
enum class PartialClearEmcy : std::uint8_t { kReset, kLatest, kNone };
// What 'load' to 0x1011 does (CiA 301 §7.5.2.14: defaults at the next reset).
enum class RestoreMode : std::uint8_t { kOnReset, kImmediate, kRam };

// The names of an enumeration's values in a profile, in value order.
template <class E>
struct EnumNames;
template <>
struct EnumNames<PartialClearEmcy> {
  static constexpr std::array<std::string_view, 3> names = {"reset", "latest", "none"};
};
template <>
struct EnumNames<RestoreMode> {
  static constexpr std::array<std::string_view, 3> names = {"on_reset", "immediate", "ram"};
};

// A set of values 0..255, written as ranges "0-240,252,254-255".
struct ByteSet {
  std::uint64_t bits[4] = {};
  bool has(std::uint8_t v) const { return (bits[v >> 6] >> (v & 63)) & 1; }
  void add(std::uint8_t v) { bits[v >> 6] |= std::uint64_t(1) << (v & 63); }
  // False on a syntax error or a value outside 0..255.
  static bool parse(std::string_view text, ByteSet& out);
  std::string text() const;  // canonical: "0-240,252-255"
  bool operator==(const ByteSet&) const = default;
};

// Up to kMax ranges of values 0..max; none = every value.
struct RangeList {
  static constexpr int kMax = 16;
  std::uint32_t lo[kMax] = {};
  std::uint32_t hi[kMax] = {};
  int count = 0;
  bool contains(std::uint64_t v) const;
  static bool parse(std::string_view text, std::uint32_t max, RangeList& out);
  std::string text(std::uint32_t max) const;  // hex when max > 255
  bool operator==(const RangeList&) const = default;
};

// Vendor SDO abort codes: every abort `from` is sent as `to` (up to kMax pairs).
struct AbortMap {
  static constexpr int kMax = 16;
  std::uint32_t from[kMax] = {};
  std::uint32_t to[kMax] = {};
  int count = 0;
  std::uint32_t apply(std::uint32_t code) const;
  static bool parse(std::string_view text, AbortMap& out);
  std::string text() const;  // "0x06090031=0x06090030,..."
  bool operator==(const AbortMap&) const = default;
};

// ---- the option kinds: each parses a profile's text into its value, says
// what it expects and writes a value back as a profile would.
namespace option_kind {
struct Bool {
  using Value = bool;
  bool parse(std::string_view text, Value& out) const;
  std::string expected() const { return "expected true or false"; }
  std::string text(Value v) const { return v ? "true" : "false"; }
};
struct Int {
  using Value = std::int64_t;
  std::int64_t lo, hi;
  bool parse(std::string_view text, Value& out) const;
  std::string expected() const;
  std::string text(Value v) const;
};
template <class E>
struct Enum {
  using Value = E;
  bool parse(std::string_view text, Value& out) const {
    for (std::size_t i = 0; i < EnumNames<E>::names.size(); ++i) {
      if (text != EnumNames<E>::names[i]) continue;
      out = E(i);
      return true;
    }
    return false;
  }
  std::string expected() const {
    std::string s = "expected one of ";
    for (std::size_t i = 0; i < EnumNames<E>::names.size(); ++i) (s += i ? ", " : "") += EnumNames<E>::names[i];
    return s;
  }
  std::string text(Value v) const { return std::string(EnumNames<E>::names[std::size_t(v)]); }
};
struct Bytes {
  using Value = ByteSet;
  bool parse(std::string_view text, Value& out) const { return ByteSet::parse(text, out); }
  std::string expected() const { return "expected ranges of values 0..255 like '0-240,252-255'"; }
  std::string text(const Value& v) const { return v.text(); }
};
struct Ranges {
  using Value = RangeList;
  std::uint32_t max;
  bool parse(std::string_view text, Value& out) const { return RangeList::parse(text, max, out); }
  std::string expected() const;
  std::string text(const Value& v) const { return v.text(max); }
};
struct Aborts {
  using Value = AbortMap;
  bool parse(std::string_view text, Value& out) const { return AbortMap::parse(text, out); }
  std::string expected() const {
    return "expected up to 16 abort code pairs 'from=to' like '0x06090031=0x06090030,0x06090032=0x06090030'";
  }
  std::string text(const Value& v) const { return v.text(); }
};

// A default as the X-macro writes it: the value, or a profile's text (a
// default the kind refuses is a bug: abort).
template <class K>
typename K::Value initial(K, typename K::Value v) {
  return v;
}
template <class K, std::size_t N>
typename K::Value initial(K kind, const char (&text)[N]) {
  typename K::Value v{};
  if (!kind.parse(text, v)) std::abort();
  return v;
}
}  // namespace option_kind

// One line each, as they read (clang-format would split them in two).
// clang-format off
#define CANSIM_OPTION_KIND_BOOL ::cansim::option_kind::Bool{}
#define CANSIM_OPTION_KIND_INT(lo, hi) ::cansim::option_kind::Int{lo, hi}
#define CANSIM_OPTION_KIND_ENUM(T) ::cansim::option_kind::Enum<T>{}
#define CANSIM_OPTION_KIND_BYTES ::cansim::option_kind::Bytes{}
#define CANSIM_OPTION_KIND_RANGES(max) ::cansim::option_kind::Ranges{max}
#define CANSIM_OPTION_KIND_ABORTS ::cansim::option_kind::Aborts{}
// clang-format on

#define CANSIM_NODE_OPTIONS(X)                                                                                      \
  /* NMT (CiA 301 §7.3.2) */                                                                                       \
  X(BOOL, nmt_auto_start, false, CIA(false), "enter OPERATIONAL by itself after boot-up")                           \
  X(INT(0, 3600000), nmt_auto_start_delay_ms, 0, SETTING, "delay between boot-up and the autonomous start")         \
  X(INT(-1, 3600000), nmt_start_all_delay_ms, -1, CIA(-1),                                                          \
    "send NMT 'start remote node' to all nodes this long after boot-up (-1: never)")                                \
  X(INT(0, 3600000), boot_up_delay_ms, 0, SETTING, "time from power-on / reset to the boot-up frame")               \
  X(INT(0, 3600000), boot_up_jitter_ms, 0, SETTING, "uniform extra 0..jitter on boot_up_delay_ms, drawn per reset") \
  X(INT(0, 0xFFFFFFFF), nmt_startup_self_start_mask, 0x08, CIA(0x08),                                               \
    "0x1F80 bits that make the node enter OPERATIONAL by itself after boot-up")                                     \
  X(BOOL, nmt_startup_self_start_if_clear, false, CIA(false),                                                       \
    "self-start when NO bit of nmt_startup_self_start_mask is set (CiA 302-2 bit 2: mask 0x04)")                    \
  X(INT(0, 0xFFFFFFFF), nmt_startup_start_all_mask, 0x02, CIA(0x02),                                                \
    "0x1F80 bits that make the node send NMT 'start remote node' to all nodes (and start)")                         \
  X(RANGES(0xFF), nmt_startup_values, "", SETTING, "0x1F80 values accepted on write (ranges; empty: any)")          \
  X(INT(0, 2), comm_error_reaction_without_1029, 1, SETTING,                                                        \
    "0x1029:01 behaviour assumed when the profile has no 0x1029 (0 pre-op, 1 none, 2 stopped)")                     \
  /* CAN controller (bus-off fault; a real interface's error frames) */                                             \
  X(INT(0, 0xFFFF), bus_off_recovery_emcy, 0x8140, CIA(0x8140),                                                     \
    "EMCY code sent when the node is back from bus-off (CiA 301 0x8140; 0: none)")                                  \
  X(INT(0, 0xFF), bus_off_recovery_emcy_register, 0, CIA(0), "0x1001 bits of that EMCY besides the class bits")     \
  X(BOOL, bus_off_recovery_emcy_clears, true, CIA(true),                                                            \
    "an error reset EMCY follows the recovery EMCY (the error is gone once the node is back)")                      \
  X(BOOL, bus_off_comm_error_reaction, true, CIA(true), "bus-off runs the 0x1029:01 communication error reaction")  \
  X(INT(0, 0xFFFF), error_passive_emcy, 0x8120, CIA(0x8120),                                                        \
    "EMCY code while the CAN controller is error passive, reset when it is error active again (CiA 301 0x8120; 0: " \
    "none)")                                                                                                        \
  X(INT(0, 0xFF), error_passive_emcy_register, 0, CIA(0), "0x1001 bits of that EMCY besides the class bits")        \
  X(INT(0, 0xFFFF), can_overrun_emcy, 0x8110, SETTING,                                                              \
    "EMCY code when the CAN controller lost frames (overflow), then its reset (CiA 301 0x8110; 0: none)")           \
  X(INT(0, 0xFF), can_overrun_emcy_register, 0, SETTING, "0x1001 bits of that EMCY besides the class bits")         \
  /* SDO server (CiA 301 §7.2.4) */                                                                                \
  X(BOOL, sdo_expedited_only, false, CIA(false), "refuse segmented and block transfers")                            \
  X(BOOL, sdo_block_transfer, true, SETTING, "support block upload / download")                                     \
  X(BOOL, sdo_upload_size_indicated, true, SETTING, "set the size bits in upload initiate responses")               \
  X(INT(0, 3600000), sdo_timeout_ms, 1000, SETTING, "abort a stalled segmented/block transfer with 0x05040000")     \
  X(INT(0, 0xFFFFFFFF), sdo_refusal_abort, 0x05040001, CIA(0x05040001),                                             \
    "abort code for a refused segmented/block initiate")                                                            \
  X(BOOL, sdo_segmented_download, true, CIA(true), "accept segmented download (false: sdo_refusal_abort)")          \
  X(BOOL, sdo_segmented_upload, true, CIA(true), "upload objects > 4 bytes segmented (false: refuse them)")         \
  X(INT(0, 0xFFFFFFFF), sdo_long_upload_abort, 0x05040001, CIA(0x05040001),                                         \
    "abort code for a refused upload of > 4 bytes")                                                                 \
  X(RANGES(0xFFFF), sdo_segmented_download_indices, "", CIA(""),                                                    \
    "indices (ranges) open to segmented/block download; others 0x06010000 ('' = all)")                              \
  X(INT(0, 8), sdo_min_request_dlc, 8, CIA(8), "ignore SDO requests shorter than this (missing bytes = 0)")         \
  X(ABORTS, sdo_abort_map, "", CIA(""), "vendor abort codes: 'from=to,...' applied to every abort")                 \
  X(BOOL, sdo_upload_response_0x60, false, CIA(false), "expedited upload responses use command byte 0x60")          \
  X(BOOL, sdo_in_stopped, false, CIA(false), "the SDO server also answers in NMT STOPPED")                          \
  X(INT(0, 10000000), sdo_turnaround_us, 0, SETTING, "time from an SDO request's arrival to its answer leaving")    \
  X(INT(0, 10000000), sdo_turnaround_jitter_us, 0, SETTING,                                                         \
    "uniform extra 0..jitter on sdo_turnaround_us, drawn per request")                                              \
  /* EMCY (CiA 301 §7.2.7) */                                                                                      \
  X(INT(0, 0xFFFFFFFF), emcy_history_bad_write_abort, 0x06090030, CIA(0x06090030),                                  \
    "abort code for writing a non-zero value to 0x1003:00")                                                         \
  X(INT(0, 0xFFFFFFFF), emcy_history_read_empty_abort, 0x08000024, CIA(0x08000024),                                 \
    "abort code for reading a 0x1003 sub above the error count (0: read the stored value)")                         \
  X(BOOL, emcy_history_register_in_info, false, SETTING,                                                            \
    "0x1003 entries carry the error register in bits 16-23 instead of manufacturer bytes 0-1")                      \
  X(BOOL, emcy_register_generic_bit, true, CIA(true), "set 0x1001 bit 0 while any error is active")                 \
  X(BOOL, emcy_register_class_bits, true, SETTING,                                                                  \
    "derive 0x1001 bits from the error code class (2xxx b1, 3xxx b2, 4xxx b3, 81xx/82xx b4, FFxx b7)")              \
  X(ENUM(PartialClearEmcy), emcy_on_partial_clear, "reset", CIA("reset"),                                           \
    "EMCY when an error clears and others stay active: reset (0x0000) | latest | none")                             \
  X(BOOL, emcy_resend_after_stopped, false, CIA(false),                                                             \
    "on leaving STOPPED, send an EMCY for every error that is still active")                                        \
  /* PDO (CiA 301 §7.2.2) */                                                                                       \
  X(BYTES, tpdo_allowed_types, "0-240,252-255", SETTING, "TPDO transmission types accepted on 0x18xx:02 (ranges)")  \
  X(INT(0, 0xFFFFFFFF), tpdo_bad_type_abort, 0x06090030, CIA(0x06090030),                                           \
    "abort code for a refused transmission type")                                                                   \
  X(INT(0, 0xFFFF), tpdo_min_event_timer_ms, 0, SETTING, "smallest non-zero TPDO event timer accepted (0: any)")    \
  X(INT(0, 0xFFFFFFFF), tpdo_event_timer_low_abort, 0x06090032, CIA(0x06090032),                                    \
    "abort code for an event timer below the minimum")                                                              \
  X(BYTES, tpdo_event_timer_types, "254-255", CIA("254-255"),                                                       \
    "TPDO types whose event timer expiry sends the PDO (others leave it to the application)")                       \
  X(BOOL, tpdo_send_empty_mapping, false, CIA(false), "a valid TPDO whose mapping has 0 entries sends DLC 0")       \
  X(BOOL, tpdo_send_on_start, false, SETTING, "event-driven TPDOs send once on entering OPERATIONAL")               \
  X(BOOL, tpdo_rtr_supported, true, SETTING, "answer RTRs on TPDO COB-IDs whose bit 30 is 0")                       \
  X(BOOL, tpdo_rtr_any_type, true, SETTING, "answer RTRs for every transmission type, not only 252/253")            \
  X(BOOL, tpdo_cobid_no_rtr_forced, false, CIA(false), "TPDO COB-ID bit 30 always reads 1, written value ignored")  \
  X(BOOL, tpdo_rtr_bit_unchecked, false, CIA(false),                                                                \
    "accept TPDO COB-IDs with bit 30 = 0 (RTR allowed) although the node answers no RTR")                           \
  X(BOOL, tpdo_dlc_always_8, false, CIA(false), "pad every TPDO with zeros to 8 data bytes")                        \
  X(BOOL, tpdo_type0_paced_by_event_timer, false, CIA(false),                                                       \
    "type 0: send on SYNC once the event timer elapsed, no event needed")                                           \
  X(BOOL, pdo_ignore_valid_bit, false, CIA(false), "COB-ID bit 31 is stored but the PDO always exists")             \
  X(BOOL, pdo_29bit_ids, true, SETTING, "accept PDO COB-IDs with bit 29 (29-bit frames)")                           \
  X(BOOL, pdo_mapping_needs_invalid, true, CIA(true),                                                               \
    "mapping writable only while the PDO is invalid (false: sub 0 = 0 suffices)")                                   \
  X(INT(0, 0xFFFFFFFF), pdo_mapping_locked_abort, 0x06090030, CIA(0x06090030),                                      \
    "abort code for a mapping write while the mapping is locked")                                                   \
  X(BOOL, rpdo_length_exceeded_emcy, true, CIA(true), "EMCY 0x8220 for an RPDO longer than its mapping")            \
  X(BOOL, rpdo_dummy_mapping, true, SETTING, "accept dummy entries 0x0001-0x0007 in RPDO mappings")                 \
  /* LSS (CiA 305) */                                                                                               \
  X(BOOL, lss_supported, true, SETTING, "answer LSS services on 0x7E5")                                             \
  X(BOOL, lss_only_in_stopped, false, CIA(false), "accept LSS configuration only in NMT STOPPED")                   \
  X(BOOL, lss_revision_zero_wildcard, false, CIA(false), "revision 0 in switch-selective matches any")              \
  X(BYTES, lss_bit_rates, "0-4,6-8", SETTING, "CiA 305 table indices the node can run at")                          \
  X(BOOL, lss_inquire_services, true, SETTING, "answer inquire identity / node-ID (0x5A-0x5E)")                     \
  X(BOOL, lss_identify_services, true, SETTING, "answer identify (non-configured) remote slave (0x46-0x4C)")        \
  X(BOOL, lss_fastscan, true, SETTING, "answer LSS fastscan (0x51) while unconfigured")                             \
  X(BOOL, lss_identify_revision_zero_wildcard, false, CIA(false),                                                   \
    "identify remote slave: revision low = high = 0 matches any revision")                                          \
  X(BOOL, lss_node_id_ff_allowed, true, CIA(true), "configure node-ID accepts 0xFF (back to unconfigured)")         \
  X(BOOL, lss_bit_timing_manual_layout, false, CIA(false),                                                          \
    "configure bit timing '13 ii 00': index in byte 1 when byte 2 is 0 (DSP 305 v1.0 manuals)")                     \
  X(BOOL, lss_table_selector_1_is_cia, false, CIA(false), "configure bit timing: selector 1 = CiA table too")       \
  X(BOOL, lss_store_supported, true, SETTING, "store configuration works (false: reply error 1)")                   \
  X(INT(0, 0xFF), lss_store_reply_cs, 0x17, CIA(0x17), "command specifier of the store configuration reply")        \
  X(BOOL, lss_nothing_to_store_error, false, CIA(false),                                                            \
    "store with nothing configured since entering configuration: reply error 0xFF, spec 1")                         \
  X(BOOL, lss_inquire_node_id_stored, false, CIA(false), "inquire node-ID reports the stored node-ID")              \
  X(BOOL, lss_activate_stored_bit_rate, false, CIA(false), "activate bit timing switches to the stored rate")       \
  X(BOOL, lss_boot_up_after_bit_rate_switch, false, CIA(false), "send a boot-up after the bit-rate switch")         \
  X(BOOL, lss_waiting_applies_stored_node_id, false, CIA(false),                                                    \
    "switch to waiting: drop unstored values; a stored node-ID != active resets communication")                     \
  X(BOOL, lss_reset_node_activates_bit_rate, false, CIA(false),                                                     \
    "NMT reset node activates the stored bit rate, like a power cycle (vendor manuals)")                            \
  X(BOOL, lss_configuration_blocks_nmt, false, CIA(false), "ignore NMT commands in LSS configuration state")        \
  X(BOOL, node_id_defaults_follow_lss, true, CIA(true),                                                             \
    "$NODEID defaults use the active node-ID (false: the configured one, so EMCY / PDO COB-IDs "                    \
    "keep their values after an LSS or vendor node-ID change)")                                                     \
  X(INT(0, 0xFFFF), node_id_object, 0, SETTING,                                                                     \
    "OD index (sub 0) holding the node-ID: its stored value is applied at power-on and reset "                      \
    "node, LSS store configuration writes it (0: none)")                                                            \
  X(INT(0, 0xFFFF), bit_rate_object, 0, SETTING,                                                                    \
    "OD index (sub 0) holding the CiA 305 bit-rate index, like node_id_object (0: none)")                           \
  /* SYNC consumer (CiA 301 §7.2.5) */                                                                             \
  X(INT(0, 0xFFFFFFFF), sync_generate_bit_abort, 0x06090030, CIA(0x06090030),                                       \
    "abort code for writing 0x1005 with bit 30 (generate) set; 0 accepts and ignores it")                           \
  X(BOOL, sync_accept_any_dlc, false, CIA(false), "accept SYNC frames of any DLC instead of EMCY 0x8240")           \
  X(INT(0, 0xFFFFFFFF), sync_cob_id_without_1005, 0, SETTING,                                                       \
    "SYNC COB-ID consumed when the profile has no 0x1005 (0: no SYNC consumer)")                                    \
  X(INT(0, 10000000), sync_tpdo_delay_us, 0, SETTING,                                                               \
    "time from a SYNC's reception to the synchronous TPDOs (types 1..240) leaving")                                 \
  X(INT(0, 10000000), sync_tpdo_jitter_us, 0, SETTING, "uniform extra 0..jitter on sync_tpdo_delay_us, per SYNC")   \
  /* Store / restore (CiA 301 §7.5.2.13-14) */                                                                     \
  X(INT(0, 0xFFFFFFFF), store_bad_signature_abort, 0x08000020, CIA(0x08000020),                                     \
    "abort code for a wrong save/load signature")                                                                   \
  X(ENUM(RestoreMode), restore_mode, "on_reset", CIA("on_reset"),                                                   \
    "0x1011: on_reset (CiA: defaults at next reset) | immediate (defaults now, stored) | ram")                      \
  /* Heartbeat consumer / guarding */                                                                               \
  X(BOOL, guarding_with_heartbeat, false, CIA(false),                                                               \
    "answer node-guarding RTRs although the heartbeat producer (0x1017) is active")                                 \
  X(INT(0, 0xFFFF), heartbeat_consumer_emcy, 0x8130, CIA(0x8130), "EMCY code on heartbeat consumer timeout")

struct NodeOptions {
#define CANSIM_DECLARE_OPTION(kind, name, def, strict, help) \
  decltype(CANSIM_OPTION_KIND_##kind)::Value name = option_kind::initial(CANSIM_OPTION_KIND_##kind, def);
  CANSIM_NODE_OPTIONS(CANSIM_DECLARE_OPTION)
#undef CANSIM_DECLARE_OPTION
};

// Sets every deviation (kind CIA) to its CiA value; settings stay.
void make_strict(NodeOptions& o);

struct OptionInfo {
  const char* name;
  bool deviation;  // kind CIA
};
// Every option in X-macro order.
const std::vector<OptionInfo>& option_infos();
const OptionInfo* find_option(std::string_view name);
// An option's value as a profile would write it ("true", "0x06090030", "on_reset").
std::string option_text(const NodeOptions& o, std::string_view name);
// The options (names, X-macro order) whose values differ between a and b.
std::vector<std::string> differing_options(const NodeOptions& a, const NodeOptions& b);

}  // namespace cansim
