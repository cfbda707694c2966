// TPDO / RPDO engine: 0x1400-0x1BFF (CiA 301 §7.2.2, objects §7.5.2.33-36).
//
// Every PDO the profile declares (0x1400+n/0x1600+n, 0x1800+n/0x1A00+n) is
// discovered once at construction; its configuration is cached from the OD at
// reset() and after every accepted write. Frame and tick paths never allocate.
//
// Timing model (sans I/O): synchronous work happens in on_sync(), event-driven
// work at absolute deadlines reported by next_deadline() (event timer, inhibit
// expiry, RPDO timeout). NMT decides whether PDOs run (Node::allowed); the
// engine keeps no copy of the state: the node tells it of every change
// (on_nmt_state), which starts or stops the PDOs.
//
// Response time after SYNC (options sync_tpdo_delay_us + 0..sync_tpdo_jitter_us,
// one draw per SYNC for all its TPDOs): the cyclic synchronous TPDOs (types
// 1..240) are sampled at the SYNC's reception (CiA 301 §7.2.2.2: synchronous
// TPDOs sample at SYNC) and leave the delay later, held as the node's
// delayed frames are (Node::send_after: an NMT change or a reset withdraws
// them). They go only when the synchronous window 0x1007 is still open at
// their departure (CiA 301 §7.2.5). Types 0 and 252 are not delayed.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/can_frame.hpp"
#include "core/protocol.hpp"
#include "core/node_options.hpp"
#include "core/node_service.hpp"
#include "core/od.hpp"
#include "core/response_time.hpp"

namespace cansim {

class Node;
enum class NmtState : std::uint8_t;

// COB-ID bits of 0x14xx:01 / 0x18xx:01 (CiA 301 Table 71 / 73).
constexpr std::uint32_t kPdoCobInvalid = cob::kInvalid;   // bit 31: PDO does not exist
constexpr std::uint32_t kPdoCobNoRtr = cob::kNoRtr;       // bit 30: no RTR allowed (TPDO)
constexpr std::uint32_t kPdoCobFrame = cob::kFrame29Bit;  // bit 29: 29-bit CAN-ID
using cob::kRxIdExtended;

// A PDO mapping entry as written to 0x16xx / 0x1Axx (CiA 301 §7.4.8.2):
// index in bits 31-16, sub-index in bits 15-8, length in bits in bits 7-0.
struct PdoMapEntry {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint8_t bits = 0;

  static constexpr PdoMapEntry decode(std::uint32_t raw) {
    return {std::uint16_t(raw >> 16), std::uint8_t(raw >> 8), std::uint8_t(raw)};
  }
  // A dummy entry names a data type index 0x0001..0x0007 (CiA 301 §7.4.7.1).
  constexpr bool dummy() const { return index >= 0x0001 && index <= 0x0007; }
};

// Checks a mapping entry against a layout as a mapping write does (CiA 301
// §7.5.2.35-36): the object exists (else 0x06020000 / 0x06090011), is
// PDO-mappable, readable for a TPDO (tx) or writable for an RPDO, and the
// length fits its type (else 0x06040041); dummy entries only where
// `dummies` allows them (RPDOs with rpdo_dummy_mapping). `mapped` receives
// the entry (null for a dummy).
SdoAbort check_pdo_map_entry(const OdLayout& od, std::uint32_t raw, bool tx, bool dummies,
                             const OdEntry** mapped = nullptr);

// One resolved mapping entry: an OD slot and a length in bits.
struct PdoMapItem {
  static constexpr std::uint16_t kDummy = 0xFFFF;  // dummy entry: bits are skipped
  std::uint16_t slot = kDummy;
  std::uint8_t bits = 0;
};

// Configuration shared by TPDOs and RPDOs, cached from the OD.
struct PdoConfig {
  static constexpr int kMaxItems = 64;    // CiA 301: sub 0 of a mapping is 0..0x40
  std::uint16_t comm_index = 0;           // 0x1400+n or 0x1800+n
  std::uint16_t map_index = 0;            // 0x1600+n or 0x1A00+n
  const OdObject* comm_object = nullptr;  // in the layout
  const OdObject* map_object = nullptr;   // null when the profile has no mapping record
  std::uint32_t cobid = kPdoCobInvalid;
  std::uint8_t type = 255;
  std::uint16_t inhibit_100us = 0;
  std::uint16_t event_ms = 0;
  std::uint8_t sync_start = 0;
  std::uint8_t item_count = 0;  // 0 when the stored mapping is empty or invalid
  std::uint8_t bits = 0;        // total mapped length
  bool declared_empty = false;  // sub 0 of the mapping is 0 (not: an invalid mapping)
  std::array<PdoMapItem, kMaxItems> items{};
};

struct Tpdo {
  PdoConfig cfg;
  TimeUs inhibit_until = 0;     // earliest time the next event-driven PDO may go out
  TimeUs event_due = kNever;    // event timer expiry (types 254/255)
  TimeUs last_sent = kNever;    // for tpdo_type0_paced_by_event_timer
  bool event_pending = false;   // application event waiting for SYNC (type 0) or inhibit
  bool sampled = false;         // type 252: `sample` holds the last SYNC sample
  std::uint8_t sync_phase = 0;  // types 1..240: see PdoEngine::on_sync_cyclic()
  CanFrame sample;
};

struct Rpdo {
  PdoConfig cfg;
  TimeUs timeout_due = kNever;  // event timer (deadline monitoring) expiry
  bool buffered = false;        // synchronous RPDO waiting for the next SYNC
  bool short_reported = false;  // EMCY 0x8210 sent, until a good frame arrives
  bool long_reported = false;   // EMCY 0x8220 sent, until a good frame arrives
  bool timed_out = false;       // EMCY 0x8250 sent, until the next RPDO
  CanFrame buffer;
};

class PdoEngine : private NodeService {
 public:
  explicit PdoEngine(Node& node);
  // Its slots of the node's deadline board (core/node_service.hpp).
  static constexpr DeadlineSlots kDeadlines{DeadlineSlot::kPdo};
  // The NodeService contract (core/node_service.hpp):
  void reset(TimeUs now);
  bool on_frame(const CanFrame& frame, TimeUs now);
  void process(TimeUs now);
  TimeUs next_deadline() const;
  // collect_rx_ids: valid RPDOs and TPDOs that accept RTR (29-bit ones carry kRxIdExtended).
  void collect_rx_ids(std::vector<std::uint32_t>& out) const;
  bool owns(std::uint16_t index) const;
  SdoAbort write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

  // Called by the SYNC consumer on every SYNC received (counter 0 when the
  // SYNC carries no counter, CiA 301 §7.2.5).
  void on_sync(std::uint8_t counter, TimeUs now);
  // Called by the node after every NMT state change.
  void on_nmt_state(NmtState old, TimeUs now);
  // Application events (CiA 301 §7.2.2.2, types 0/254/255): 1-based TPDO number.
  // Without a time the PDO goes out at the next advance (it reports itself due).
  void raise_event(unsigned tpdo_number);
  void raise_event(unsigned tpdo_number, TimeUs now);
  // Raises an event on every valid event-driven/acyclic TPDO that maps `e`.
  void raise_event_for(const OdEntry& e);
  // The application rewrote the mapping of a TPDO (vendor mapping modes):
  // re-read it and restart the PDO as a mapping write does. 1-based number.
  void mapping_changed(unsigned tpdo_number, TimeUs now);

  std::size_t tpdo_count() const { return tpdos_.size(); }
  std::size_t rpdo_count() const { return rpdos_.size(); }
  // The TPDOs as the engine runs them: COB-ID, type and the resolved mapping
  // (valid when the configuration is). The application is told of every
  // change by Application::on_pdo_config().
  std::span<const Tpdo> tpdos() const { return tpdos_; }
  // TPDO `number` (1-based, 0x1800 + number - 1), null when the profile has none.
  const Tpdo* tpdo(unsigned number) const;
  std::span<const Rpdo> rpdos() const { return rpdos_; }
  // The PDO exists: COB-ID bit 31 clear (or the vendor ignores the bit).
  bool valid(const PdoConfig& cfg) const;
  // The mapping TPDO `number` holds now (sub 0 and its entries) as CiA 301's
  // mapping rule judges it (§7.5.2.36: entries exist, are mappable and fit
  // 64 bits): kNone when the PDO could run with it.
  SdoAbort tpdo_mapping_status(unsigned number) const;

 private:
  // ---- configuration
  void load(PdoConfig& cfg, bool tx);
  void load_mapping(PdoConfig& cfg, bool tx);
  void config_changed(TimeUs now);
  bool locked(const PdoConfig& cfg) const;  // CiA 301: "while the PDO exists"
  const OdEntry* comm_entry(const PdoConfig& cfg, std::uint8_t sub) const;
  const OdEntry* map_entry(const PdoConfig& cfg, std::uint8_t sub) const;
  // `mapped` (optional) receives the named entry (null for a dummy entry).
  SdoAbort check_map_entry(std::uint32_t raw, bool tx, const OdEntry** mapped = nullptr) const;
  SdoAbort check_cobid(const PdoConfig& cfg, bool tx, std::uint32_t& v) const;
  SdoAbort check_comm(const PdoConfig& cfg, bool tx, std::uint8_t sub, std::uint32_t& v) const;
  SdoAbort check_map_count(const PdoConfig& cfg, bool tx, std::uint32_t n) const;
  SdoAbort check_mapping(const PdoConfig& cfg, bool tx, std::uint32_t n) const;  // entries 1..n
  SdoAbort check_map_write(const PdoConfig& cfg, bool tx, std::uint8_t sub, std::uint32_t v) const;
  void after_config_change(PdoConfig& cfg, bool tx, std::uint8_t comm_sub, TimeUs now);
  void restart(PdoConfig& cfg, bool tx, std::uint8_t comm_sub, TimeUs now);
  Tpdo* find_tpdo(const PdoConfig& cfg);
  Rpdo* find_rpdo(const PdoConfig& cfg);

  // ---- NMT
  bool running() const;  // PDOs are allowed in the node's NMT state
  void arm(Tpdo& t, TimeUs now);
  void arm(Rpdo& r);
  void disarm(Tpdo& t);

  // ---- TPDO
  static bool event_driven(std::uint8_t type) { return type >= 254; }
  bool timer_sends(const PdoConfig& cfg) const;
  void on_sync_tpdo(Tpdo& t, std::uint8_t counter, TimeUs now, TimeUs delay);
  void on_sync_cyclic(Tpdo& t, std::uint8_t counter, TimeUs now, TimeUs delay);
  void on_rtr(Tpdo& t, TimeUs now);
  void process_tpdo(Tpdo& t, TimeUs now);
  void send_event_driven(Tpdo& t, TimeUs now, TimeUs timer_base);
  bool build(Tpdo& t, TimeUs now, CanFrame& out);
  // Sampled now, on the wire `delay` later.
  void transmit(Tpdo& t, TimeUs now, TimeUs delay = 0);

  // ---- RPDO
  void on_rpdo(Rpdo& r, const CanFrame& frame, TimeUs now);
  void apply(Rpdo& r, TimeUs now);
  void store_received(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now);

  void update_deadline();

  std::vector<Tpdo> tpdos_;  // sized once at construction
  std::vector<Rpdo> rpdos_;
  // Indices of the valid event-driven TPDOs and of the RPDOs with deadline
  // monitoring: the periodic work touches only these (a node's TPDOs are
  // cold in the cache; most are synchronous, RTR-only or invalid).
  std::vector<std::uint16_t> event_tpdos_;
  std::vector<std::uint16_t> watched_rpdos_;
  void index_active();
  Deadline next_{node_, kDeadlines.first};
  ResponseTime sync_delay_{ResponseTime::Stream::kSyncTpdo};
};

}  // namespace cansim
