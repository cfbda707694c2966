#include "core/pdo.hpp"

#include <algorithm>
#include <cstring>

#include "core/node.hpp"

namespace cansim {

namespace {

constexpr std::uint16_t kRpdoComm = 0x1400, kRpdoMap = 0x1600;
constexpr std::uint16_t kTpdoComm = 0x1800, kTpdoMap = 0x1A00;
constexpr std::uint16_t kPdoRange = 0x200;                // up to 512 PDOs of each kind
constexpr std::uint32_t kChangeLockedBits = 0x3FFFFFFFu;  // all but bits 31/30
constexpr std::uint8_t kTypeAcyclicSync = 0;
constexpr std::uint8_t kTypeLastCyclic = 240;
constexpr std::uint8_t kTypeRtrSync = 252;
constexpr std::uint8_t kTypeRtrAsync = 253;
constexpr std::uint8_t kCommunicationErrorBit = 0x10;  // error register bit 4 (CiA 301 Table 48)

// Sub-indices of the communication parameter records (CiA 301 §7.5.2.33/35).
enum : std::uint8_t { kSubCobId = 1, kSubType = 2, kSubInhibit = 3, kSubEvent = 5, kSubSyncStart = 6 };

// TPDO sync phase (types 1..240), after CANopenNode's counter semantics.
enum : std::uint8_t { kPhaseUnarmed = 0, kPhaseWaitStart = 255 };

bool frame_matches(std::uint32_t cobid, const CanFrame& f) {
  return f.id == cob::can_id(cobid) && f.extended() == bool(cobid & kPdoCobFrame);
}

bool reserved_tpdo_type(std::uint32_t t) { return t > kTypeLastCyclic && t < kTypeRtrSync; }
// Types 1..240: every n-th SYNC (CiA 301 Table 72).
bool cyclic_sync_type(std::uint8_t t) { return t != kTypeAcyclicSync && t <= kTypeLastCyclic; }
bool reserved_rpdo_type(std::uint32_t t) { return t > kTypeLastCyclic && t < 254; }

std::uint8_t map_bits(std::uint32_t raw) { return PdoMapEntry::decode(raw).bits; }

// Length in bits an object of type t may be mapped with. BOOLEAN may be
// mapped as one bit (CiA 301 §7.1.4.2) or as its byte.
bool length_fits(DataType t, std::uint32_t capacity, unsigned bits) {
  if (bits == 0) return false;
  if (t == DataType::kBoolean) return bits == 1 || bits == 8;
  if (is_variable_size(t)) return bits % 8 == 0 && bits / 8 <= capacity;
  return bits == type_size(t) * 8;
}

// PDO data is the mapped objects back to back, each little-endian, from bit 0
// of byte 0 (CiA 301 §7.2.2.1). Copies `bits` bits from `src` bit 0 to `dst`
// at bit offset `at`.
void put_bits(std::uint8_t* dst, unsigned at, const std::uint8_t* src, unsigned bits) {
  if (at % 8 == 0 && bits % 8 == 0) {
    std::memcpy(dst + at / 8, src, bits / 8);
    return;
  }
  for (unsigned i = 0; i < bits; ++i) {
    const bool bit = (src[i / 8] >> (i % 8)) & 1;
    const unsigned d = at + i;
    const auto mask = std::uint8_t(1u << (d % 8));
    dst[d / 8] = bit ? std::uint8_t(dst[d / 8] | mask) : std::uint8_t(dst[d / 8] & ~mask);
  }
}

// Copies `bits` bits from `src` at bit offset `at` to `dst` bit 0 (dst zeroed by the caller).
void get_bits(std::uint8_t* dst, const std::uint8_t* src, unsigned at, unsigned bits) {
  for (unsigned i = 0; i < bits; ++i) {
    const unsigned s = at + i;
    if ((src[s / 8] >> (s % 8)) & 1) dst[i / 8] = std::uint8_t(dst[i / 8] | (1u << (i % 8)));
  }
}

// EMCY hand-off: Emcy::raise(code, register bits, mfr, now) / clear(code, now).
// Resolved at compile time so this file builds whatever state emcy.hpp is in.
template <typename E>
void raise_emcy(E& emcy, std::uint16_t code, TimeUs now) {
  if constexpr (requires(E & e) { e.raise(code, kCommunicationErrorBit, {}, now); }) {
    emcy.raise(code, kCommunicationErrorBit, {}, now);
  } else {
    (void)emcy, (void)code, (void)now;  // no EMCY producer in this build
  }
}

template <typename E>
void clear_emcy(E& emcy, std::uint16_t code, TimeUs now) {
  if constexpr (requires(E & e) { e.clear(code, now); }) {
    emcy.clear(code, now);
  } else {
    (void)emcy, (void)code, (void)now;
  }
}

// Synchronous PDOs go out only inside the synchronous window 0x1007 (CiA 301 §7.2.5).
template <typename S>
bool sync_window_open(const S& sync, TimeUs now) {
  if constexpr (requires(const S& s) { s.window_open(now); }) {
    return sync.window_open(now);
  } else {
    (void)sync, (void)now;
    return true;
  }
}

}  // namespace

// ---------------------------------------------------------------------------
// Construction, reset, NMT

PdoEngine::PdoEngine(Node& node) : NodeService(node) {
  for (const OdObject& o : node_.od().objects()) {
    if (o.index >= kTpdoComm && o.index < kTpdoComm + kPdoRange) {
      Tpdo t;
      t.cfg.comm_index = o.index;
      t.cfg.map_index = std::uint16_t(o.index - kTpdoComm + kTpdoMap);
      t.cfg.comm_object = &o;
      t.cfg.map_object = node_.od().object(t.cfg.map_index);
      tpdos_.push_back(t);
    } else if (o.index >= kRpdoComm && o.index < kRpdoComm + kPdoRange) {
      Rpdo r;
      r.cfg.comm_index = o.index;
      r.cfg.map_index = std::uint16_t(o.index - kRpdoComm + kRpdoMap);
      r.cfg.comm_object = &o;
      r.cfg.map_object = node_.od().object(r.cfg.map_index);
      rpdos_.push_back(r);
    }
  }
  tpdos_.shrink_to_fit();
  rpdos_.shrink_to_fit();
  event_tpdos_.reserve(tpdos_.size());
  watched_rpdos_.reserve(rpdos_.size());
}

void PdoEngine::reset(TimeUs now) {
  const NodeOptions& o = node_.options();
  sync_delay_.set(o.sync_tpdo_delay_us, o.sync_tpdo_jitter_us);
  if (sync_delay_.any()) node_.frame_faults().reserve_held();  // not on the SYNC path
  const bool run = running();
  for (Tpdo& t : tpdos_) {
    load(t.cfg, true);
    disarm(t);
    if (run) arm(t, now);
  }
  for (Rpdo& r : rpdos_) {
    load(r.cfg, false);
    arm(r);
    r.short_reported = r.long_reported = r.timed_out = false;  // EMCY was reset too
  }
  index_active();
  update_deadline();
  config_changed(now);
}

// CiA 404 devices and vendors act on what the TPDOs map (event channels,
// mapping modes); they are told instead of polling the OD.
void PdoEngine::config_changed(TimeUs now) {
  if (Application* app = node_.app()) app->on_pdo_config(node_, now);
  if (NodeObserver* o = node_.observer()) o->on_pdo_config(node_, now);
}

void PdoEngine::index_active() {
  event_tpdos_.clear();
  for (std::size_t i = 0; i < tpdos_.size(); ++i)
    if (valid(tpdos_[i].cfg) && event_driven(tpdos_[i].cfg.type)) event_tpdos_.push_back(std::uint16_t(i));
  watched_rpdos_.clear();
  for (std::size_t i = 0; i < rpdos_.size(); ++i)
    if (rpdos_[i].cfg.event_ms) watched_rpdos_.push_back(std::uint16_t(i));
}

bool PdoEngine::running() const { return node_.allowed(Service::kPdo); }

// Entering OPERATIONAL starts the PDOs afresh; leaving it stops them (CiA 301 §7.3.2.2).
void PdoEngine::on_nmt_state(NmtState old, TimeUs now) {
  const bool run = running();
  if (run == node_.allowed_in(old, Service::kPdo)) return;
  for (Tpdo& t : tpdos_) {
    disarm(t);
    if (run) arm(t, now);
  }
  for (Rpdo& r : rpdos_) arm(r);
  update_deadline();
}

void PdoEngine::disarm(Tpdo& t) {
  t.event_due = kNever;
  t.event_pending = false;
  t.sampled = false;
  t.sync_phase = kPhaseUnarmed;
  t.last_sent = kNever;
  t.inhibit_until = 0;
}

// Event-driven TPDOs start their event timer (one period after the start, or
// at once with tpdo_send_on_start); synchronous ones wait for SYNC.
void PdoEngine::arm(Tpdo& t, TimeUs now) {
  disarm(t);
  t.inhibit_until = now;
  if (!valid(t.cfg) || !event_driven(t.cfg.type)) return;
  if (node_.options().tpdo_send_on_start && t.cfg.item_count > 0) {
    send_event_driven(t, now, now);
  } else if (timer_sends(t.cfg)) {
    t.event_due = now + node_.local_duration(ms(t.cfg.event_ms));
  }
}

// RPDO deadline monitoring starts with the first reception (CiA 301 §7.5.2.33).
void PdoEngine::arm(Rpdo& r) {
  r.timeout_due = kNever;
  r.buffered = false;
}

// ---------------------------------------------------------------------------
// Configuration cache

const Tpdo* PdoEngine::tpdo(unsigned number) const {
  for (const Tpdo& t : tpdos_)
    if (unsigned(t.cfg.comm_index - kTpdoComm + 1) == number) return &t;
  return nullptr;
}

SdoAbort PdoEngine::tpdo_mapping_status(unsigned number) const {
  const Tpdo* t = tpdo(number);
  if (!t) return SdoAbort::kNoObject;
  const OdEntry* count = map_entry(t->cfg, 0);
  return count ? check_mapping(t->cfg, true, std::uint32_t(node_.values().get_u(*count))) : SdoAbort::kNoObject;
}

bool PdoEngine::timer_sends(const PdoConfig& cfg) const {
  return cfg.event_ms && node_.options().tpdo_event_timer_types.has(cfg.type);
}

bool PdoEngine::valid(const PdoConfig& cfg) const {
  return node_.options().pdo_ignore_valid_bit || !(cfg.cobid & kPdoCobInvalid);
}

bool PdoEngine::locked(const PdoConfig& cfg) const {
  return !node_.options().pdo_ignore_valid_bit && !(cfg.cobid & kPdoCobInvalid);
}

const OdEntry* PdoEngine::comm_entry(const PdoConfig& cfg, std::uint8_t sub) const {
  return node_.od().find(*cfg.comm_object, sub);
}

const OdEntry* PdoEngine::map_entry(const PdoConfig& cfg, std::uint8_t sub) const {
  return cfg.map_object ? node_.od().find(*cfg.map_object, sub) : nullptr;
}

void PdoEngine::load(PdoConfig& cfg, bool tx) {
  const OdValues& v = node_.values();
  auto get = [&](std::uint8_t sub, std::uint64_t fallback) {
    const OdEntry* e = comm_entry(cfg, sub);
    return e ? v.get_u(*e) : fallback;
  };
  cfg.cobid = std::uint32_t(get(kSubCobId, kPdoCobInvalid));
  cfg.type = std::uint8_t(get(kSubType, 255));
  cfg.inhibit_100us = tx ? std::uint16_t(get(kSubInhibit, 0)) : 0;
  cfg.event_ms = std::uint16_t(get(kSubEvent, 0));
  cfg.sync_start = tx ? std::uint8_t(get(kSubSyncStart, 0)) : 0;
  load_mapping(cfg, tx);
}

// Resolves 0x16xx/0x1Axx into slots. A stored mapping that does not pass the
// write checks (e.g. restored from an old file) leaves the PDO empty.
void PdoEngine::load_mapping(PdoConfig& cfg, bool tx) {
  cfg.item_count = 0;
  cfg.bits = 0;
  cfg.declared_empty = false;
  const OdEntry* count = map_entry(cfg, 0);
  if (!count) return;
  const auto n = unsigned(std::min<std::uint64_t>(node_.values().get_u(*count), PdoConfig::kMaxItems));
  cfg.declared_empty = n == 0;
  unsigned bits = 0;
  for (unsigned i = 1; i <= n; ++i) {
    const OdEntry* e = map_entry(cfg, std::uint8_t(i));
    const std::uint32_t raw = e ? std::uint32_t(node_.values().get_u(*e)) : 0;
    const OdEntry* mapped = nullptr;
    if (raw == 0 || !ok(check_map_entry(raw, tx, &mapped))) return;
    bits += map_bits(raw);
    if (bits > 64) return;
    PdoMapItem& item = cfg.items[i - 1];
    item.bits = map_bits(raw);
    item.slot = mapped ? mapped->slot : PdoMapItem::kDummy;
  }
  cfg.item_count = std::uint8_t(n);
  cfg.bits = std::uint8_t(bits);
}

// ---------------------------------------------------------------------------
// OD writes (CiA 301 §7.5.2.33-36)

bool PdoEngine::owns(std::uint16_t index) const {
  auto has = [&](const auto& list, std::uint16_t comm) {
    return std::any_of(list.begin(), list.end(), [&](const auto& p) { return p.cfg.comm_index == comm; });
  };
  if (index >= kRpdoComm && index < kRpdoComm + kPdoRange) return has(rpdos_, index);
  if (index >= kRpdoMap && index < kRpdoMap + kPdoRange) return has(rpdos_, index - kRpdoMap + kRpdoComm);
  if (index >= kTpdoComm && index < kTpdoComm + kPdoRange) return has(tpdos_, index);
  if (index >= kTpdoMap && index < kTpdoMap + kPdoRange) return has(tpdos_, index - kTpdoMap + kTpdoComm);
  return false;
}

SdoAbort PdoEngine::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  const bool tx = e.index >= kTpdoComm;
  const bool mapping = tx ? e.index >= kTpdoMap : e.index >= kRpdoMap;
  const std::uint16_t comm = std::uint16_t(mapping ? e.index - (kTpdoMap - kTpdoComm) : e.index);
  PdoConfig* cfg = nullptr;
  if (tx) {
    for (Tpdo& t : tpdos_)
      if (t.cfg.comm_index == comm) cfg = &t.cfg;
  } else {
    for (Rpdo& r : rpdos_)
      if (r.cfg.comm_index == comm) cfg = &r.cfg;
  }
  if (!cfg) return SdoAbort::kNoObject;

  std::uint32_t v = data.size() <= 4 && !is_variable_size(e.type) ? std::uint32_t(decode_u(e.type, data.data())) : 0;
  const std::uint32_t old = std::uint32_t(node_.values().get_u(e));
  SdoAbort a = SdoAbort::kNone;
  if (mapping) {
    a = e.sub == 0 ? check_map_count(*cfg, tx, v) : check_map_write(*cfg, tx, e.sub, v);
  } else {
    a = check_comm(*cfg, tx, e.sub, v);
  }
  if (!ok(a)) return a;
  if (v == old) return SdoAbort::kNone;  // rewriting the current value is always accepted

  Application* app = (e.hooks & kHookWrite) ? node_.app() : nullptr;
  std::uint8_t bytes[4];
  encode_u(e.type, v, bytes);
  const std::span<const std::uint8_t> stored(bytes, type_size(e.type));
  if (app) {
    if (SdoAbort h = app->check_write(node_, e, stored, now); !ok(h)) return h;
  }
  node_.values().set_bytes(e, stored);
  after_config_change(*cfg, tx, mapping ? 0 : e.sub, now);
  if (mapping) node_.rx_changed();
  if (app) app->after_write(node_, e, now);
  update_deadline();
  return SdoAbort::kNone;
}

SdoAbort PdoEngine::check_comm(const PdoConfig& cfg, bool tx, std::uint8_t sub, std::uint32_t& v) const {
  const NodeOptions& o = node_.options();
  switch (sub) {
    case kSubCobId: return check_cobid(cfg, tx, v);
    case kSubType:
      if (v == cfg.type) return SdoAbort::kNone;
      if (!tx) return reserved_rpdo_type(v) ? SdoAbort::kInvalidValue : SdoAbort::kNone;
      if (reserved_tpdo_type(v) || !node_.options().tpdo_allowed_types.has(std::uint8_t(v)))
        return SdoAbort(o.tpdo_bad_type_abort);
      // RTR-only types need RTR (COB-ID bit 30 = 0).
      if ((v == kTypeRtrSync || v == kTypeRtrAsync) && ((cfg.cobid & kPdoCobNoRtr) || !o.tpdo_rtr_supported))
        return SdoAbort::kInvalidValue;
      return SdoAbort::kNone;
    case kSubInhibit:
      // CiA 301 §7.5.2.35: not changeable while the PDO exists.
      return tx && v != cfg.inhibit_100us && locked(cfg) ? SdoAbort::kInvalidValue : SdoAbort::kNone;
    case kSubEvent:
      if (tx && v != 0 && v < std::uint64_t(o.tpdo_min_event_timer_ms)) return SdoAbort(o.tpdo_event_timer_low_abort);
      return SdoAbort::kNone;
    case kSubSyncStart:
      if (!tx) return SdoAbort::kNone;
      if (v > kTypeLastCyclic) return SdoAbort::kInvalidValue;
      return v != cfg.sync_start && locked(cfg) ? SdoAbort::kInvalidValue : SdoAbort::kNone;
    default: return SdoAbort::kNone;  // sub 4 (reserved) and vendor subs: stored as is
  }
}

// CiA 301 §7.5.2.33/35 COB-ID rules; may adjust v (forced bit 30).
SdoAbort PdoEngine::check_cobid(const PdoConfig& cfg, bool tx, std::uint32_t& v) const {
  const NodeOptions& o = node_.options();
  if (tx && o.tpdo_cobid_no_rtr_forced) v |= kPdoCobNoRtr;
  if (v == cfg.cobid) return SdoAbort::kNone;
  // Bit 30 = 0 says "RTR allowed" (§7.5.2.35): refused by a node without RTR.
  if (tx && !(v & kPdoCobNoRtr) && !o.tpdo_rtr_supported && !o.tpdo_rtr_bit_unchecked) return SdoAbort::kInvalidValue;
  const bool will_exist = !(v & kPdoCobInvalid);
  if (locked(cfg) && will_exist && ((v ^ cfg.cobid) & kChangeLockedBits)) return SdoAbort::kInvalidValue;
  if (!cob::format_ok(v)) return SdoAbort::kInvalidValue;  // 11-bit CAN-ID with bits 11..28 set
  if (v & kPdoCobFrame) {
    if (!o.pdo_29bit_ids) return SdoAbort::kInvalidValue;
  } else if ((will_exist || o.pdo_ignore_valid_bit) && cob::restricted(cob::can_id(v))) {
    return SdoAbort::kInvalidValue;
  }
  return SdoAbort::kNone;
}

// Sub 0 = n enables the mapping: entries 1..n must be valid and fit 64 bits
// (CiA 301 §7.5.2.36 step 4).
SdoAbort PdoEngine::check_map_count(const PdoConfig& cfg, bool tx, std::uint32_t n) const {
  const OdEntry* count = map_entry(cfg, 0);
  if (count && n == node_.values().get_u(*count)) return SdoAbort::kNone;
  if (node_.options().pdo_mapping_needs_invalid && locked(cfg))
    return SdoAbort(node_.options().pdo_mapping_locked_abort);
  return check_mapping(cfg, tx, n);
}

SdoAbort PdoEngine::check_mapping(const PdoConfig& cfg, bool tx, std::uint32_t n) const {
  // More entries than the mapping record has sub-indices.
  if (n > PdoConfig::kMaxItems || (n > 0 && !map_entry(cfg, std::uint8_t(n)))) return SdoAbort::kValueTooHigh;
  unsigned bits = 0;
  for (unsigned i = 1; i <= n; ++i) {
    const OdEntry* e = map_entry(cfg, std::uint8_t(i));
    if (!e) return SdoAbort::kNotMappable;
    const std::uint32_t raw = std::uint32_t(node_.values().get_u(*e));
    if (raw == 0) return SdoAbort::kNotMappable;
    bits += map_bits(raw);
    if (bits > 64) return SdoAbort::kPdoLength;
    if (SdoAbort a = check_map_entry(raw, tx); !ok(a)) return a;
  }
  return SdoAbort::kNone;
}

// Entries change only while the PDO does not exist and sub 0 is 0 (CiA 301
// §7.5.2.36 steps 1-3); a non-zero entry must name a mappable object.
SdoAbort PdoEngine::check_map_write(const PdoConfig& cfg, bool tx, std::uint8_t sub, std::uint32_t v) const {
  const OdEntry* e = map_entry(cfg, sub);
  if (e && v == node_.values().get_u(*e)) return SdoAbort::kNone;
  const OdEntry* count = map_entry(cfg, 0);
  const bool enabled = count && node_.values().get_u(*count) != 0;
  if (enabled || (node_.options().pdo_mapping_needs_invalid && locked(cfg)))
    return SdoAbort(node_.options().pdo_mapping_locked_abort);
  return v == 0 ? SdoAbort::kNone : check_map_entry(v, tx);
}

// One mapping entry: 0x06020000 / 0x06090011 when the object is missing,
// 0x06040041 when it is not mappable, not readable (TPDO) / writable (RPDO),
// or its length does not match the type.
SdoAbort check_pdo_map_entry(const OdLayout& od, std::uint32_t raw, bool tx, bool dummies, const OdEntry** mapped) {
  const PdoMapEntry m = PdoMapEntry::decode(raw);
  if (mapped) *mapped = nullptr;
  if (m.dummy()) {
    if (tx || !dummies || m.sub != 0) return SdoAbort::kNotMappable;
    return length_fits(DataType(m.index), 0, m.bits) ? SdoAbort::kNone : SdoAbort::kNotMappable;
  }
  SdoAbort why = SdoAbort::kNone;
  const OdEntry* e = od.lookup(m.index, m.sub, why);
  if (!e) return why;
  if (!e->pdo_mappable) return SdoAbort::kNotMappable;
  if (tx ? !readable(e->access) : !writable(e->access)) return SdoAbort::kNotMappable;
  if (!length_fits(e->type, e->capacity, m.bits)) return SdoAbort::kNotMappable;
  if (mapped) *mapped = e;
  return SdoAbort::kNone;
}

SdoAbort PdoEngine::check_map_entry(std::uint32_t raw, bool tx, const OdEntry** mapped) const {
  return check_pdo_map_entry(node_.od(), raw, tx, node_.options().rpdo_dummy_mapping, mapped);
}

Tpdo* PdoEngine::find_tpdo(const PdoConfig& cfg) {
  for (Tpdo& t : tpdos_)
    if (&t.cfg == &cfg) return &t;
  return nullptr;
}

Rpdo* PdoEngine::find_rpdo(const PdoConfig& cfg) {
  for (Rpdo& r : rpdos_)
    if (&r.cfg == &cfg) return &r;
  return nullptr;
}

// Re-reads the PDO and reacts: a new COB-ID, type or mapping restarts the PDO;
// a new event timer restarts the timer only.
void PdoEngine::after_config_change(PdoConfig& cfg, bool tx, std::uint8_t comm_sub, TimeUs now) {
  restart(cfg, tx, comm_sub, now);
  config_changed(now);
}

void PdoEngine::restart(PdoConfig& cfg, bool tx, std::uint8_t comm_sub, TimeUs now) {
  const std::uint32_t old_cobid = cfg.cobid;
  load(cfg, tx);
  index_active();
  if (old_cobid != cfg.cobid) node_.rx_changed();  // RPDO / RTR dispatch set
  if (!tx) {
    Rpdo& r = *find_rpdo(cfg);
    if (comm_sub != kSubEvent) arm(r);
    else if (cfg.event_ms == 0) r.timeout_due = kNever;
    return;
  }
  Tpdo& t = *find_tpdo(cfg);
  if (!running()) return;
  if (comm_sub == kSubEvent) {
    t.event_due = valid(cfg) && event_driven(cfg.type) && timer_sends(cfg)
                      ? now + node_.local_duration(ms(cfg.event_ms))
                      : kNever;
  } else if (comm_sub == kSubCobId || comm_sub == kSubType || comm_sub == 0) {
    const TimeUs inhibit = t.inhibit_until;
    t.event_due = kNever;
    t.event_pending = false;
    t.sampled = false;
    t.sync_phase = kPhaseUnarmed;
    if (valid(cfg) && event_driven(cfg.type) && timer_sends(cfg))
      t.event_due = now + node_.local_duration(ms(cfg.event_ms));
    t.inhibit_until = std::max(inhibit, now);
  }
}

// ---------------------------------------------------------------------------
// Frames, SYNC, time

bool PdoEngine::on_frame(const CanFrame& frame, TimeUs now) {
  const NodeOptions& o = node_.options();
  if (frame.rtr()) {
    if (!o.tpdo_rtr_supported) return false;
    for (Tpdo& t : tpdos_) {
      if (!valid(t.cfg) || (t.cfg.cobid & kPdoCobNoRtr) || !frame_matches(t.cfg.cobid, frame)) continue;
      if (running()) on_rtr(t, now);
      update_deadline();
      return true;
    }
    return false;
  }
  for (Rpdo& r : rpdos_) {
    if (!valid(r.cfg) || !frame_matches(r.cfg.cobid, frame)) continue;
    if (running()) on_rpdo(r, frame, now);
    update_deadline();
    return true;
  }
  return false;
}

void PdoEngine::on_sync(std::uint8_t counter, TimeUs now) {
  if (running()) {
    // Synchronous RPDOs received before this SYNC are actuated now (CiA 301 §7.2.2.2).
    for (Rpdo& r : rpdos_)
      if (r.buffered) apply(r, now);
    // Synchronous TPDOs are sampled at the SYNC itself; the cyclic ones leave
    // the device's response time later, the others at once. Each goes when
    // the window is open at its departure.
    const TimeUs delay = sync_delay_.next(node_.seed());
    const bool window = sync_window_open(node_.sync(), now);
    const bool window_later = delay == 0 ? window : sync_window_open(node_.sync(), now + delay);
    for (Tpdo& t : tpdos_) {
      if (valid(t.cfg) && (cyclic_sync_type(t.cfg.type) ? window_later : window)) on_sync_tpdo(t, counter, now, delay);
    }
  }
  update_deadline();
}

void PdoEngine::on_sync_tpdo(Tpdo& t, std::uint8_t counter, TimeUs now, TimeUs delay) {
  const std::uint8_t type = t.cfg.type;
  if (type == kTypeAcyclicSync) {
    if (node_.options().tpdo_type0_paced_by_event_timer) {
      // Vendor meaning (GEMS 9000): every SYNC once the event timer elapsed.
      if (t.cfg.event_ms == 0 || t.last_sent == kNever || now - t.last_sent >= node_.local_duration(ms(t.cfg.event_ms)))
        transmit(t, now);
    } else if (t.event_pending) {
      t.event_pending = false;
      transmit(t, now);
    }
  } else if (type <= kTypeLastCyclic) {
    on_sync_cyclic(t, counter, now, delay);
  } else if (type == kTypeRtrSync) {
    t.sampled = build(t, now, t.sample);
  }
}

// Every n-th SYNC. The first transmission waits for SYNC counter == start
// value when the SYNC carries a counter and the start value is not 0 (CiA 301
// §7.5.2.35 sub 6); otherwise the first SYNC after start counts as number 1.
void PdoEngine::on_sync_cyclic(Tpdo& t, std::uint8_t counter, TimeUs now, TimeUs delay) {
  if (t.sync_phase == kPhaseUnarmed)
    t.sync_phase = (counter != 0 && t.cfg.sync_start != 0) ? std::uint8_t(kPhaseWaitStart) : t.cfg.type;
  if (t.sync_phase == kPhaseWaitStart) {
    if (counter != t.cfg.sync_start) return;
    t.sync_phase = t.cfg.type;
    transmit(t, now, delay);
    return;
  }
  if (--t.sync_phase == 0) {
    t.sync_phase = t.cfg.type;
    transmit(t, now, delay);
  }
}

// RTR on the TPDO COB-ID (bit 30 = 0): 252 answers with the data sampled at
// the last SYNC, 253 samples now (CiA 301 Table 72). Other types answer with
// fresh data when tpdo_rtr_any_type (bit 30 allows RTR per PDO, not per type).
void PdoEngine::on_rtr(Tpdo& t, TimeUs now) {
  if (t.cfg.type == kTypeRtrSync) {
    if (t.sampled) node_.send(t.sample);
    return;
  }
  if (t.cfg.type == kTypeRtrAsync || node_.options().tpdo_rtr_any_type) transmit(t, now);
}

void PdoEngine::process(TimeUs now) {
  if (running()) {
    for (std::uint16_t i : event_tpdos_) process_tpdo(tpdos_[i], now);
    for (std::uint16_t i : watched_rpdos_) {
      Rpdo& r = rpdos_[i];
      if (r.timeout_due > now) continue;
      r.timeout_due = kNever;  // once per silence, re-armed by the next RPDO
      r.timed_out = true;
      raise_emcy(node_.emcy(), emcy::kRpdoTimeout, now);
    }
  }
  update_deadline();
}

// Event timer expiry and application events, held back by the inhibit time
// (CiA 301 §7.5.2.35 sub 3: delayed, not lost).
void PdoEngine::process_tpdo(Tpdo& t, TimeUs now) {
  TimeUs timer_base = now;
  if (t.event_due <= now) {
    t.event_pending = true;
    // Absolute deadlines: the next period counts from the expiry, not from
    // when we got to run, unless the inhibit time delayed the transmission.
    timer_base = std::max(t.event_due, t.inhibit_until);
    t.event_due = kNever;
  }
  if (t.event_pending && t.inhibit_until <= now) send_event_driven(t, now, timer_base);
}

void PdoEngine::send_event_driven(Tpdo& t, TimeUs now, TimeUs timer_base) {
  t.event_pending = false;
  transmit(t, now);
  t.inhibit_until = now + node_.local_duration(TimeUs(t.cfg.inhibit_100us) * 100);
  // The event timer restarts with every event-driven transmission.
  t.event_due = timer_sends(t.cfg) ? timer_base + node_.local_duration(ms(t.cfg.event_ms)) : kNever;
}

void PdoEngine::raise_event(unsigned tpdo_number) {
  for (Tpdo& t : tpdos_) {
    if (unsigned(t.cfg.comm_index - kTpdoComm + 1) != tpdo_number) continue;
    if (running() && valid(t.cfg) && (t.cfg.type == kTypeAcyclicSync || event_driven(t.cfg.type)))
      t.event_pending = true;
  }
  update_deadline();
}

void PdoEngine::raise_event(unsigned tpdo_number, TimeUs now) {
  raise_event(tpdo_number);
  for (Tpdo& t : tpdos_)
    if (valid(t.cfg) && event_driven(t.cfg.type) && t.event_pending && t.inhibit_until <= now)
      send_event_driven(t, now, now);
  update_deadline();
}

void PdoEngine::raise_event_for(const OdEntry& e) {
  for (const Tpdo& t : tpdos_) {
    const auto items = std::span(t.cfg.items).first(t.cfg.item_count);
    if (std::any_of(items.begin(), items.end(), [&](const PdoMapItem& i) { return i.slot == e.slot; }))
      raise_event(unsigned(t.cfg.comm_index - kTpdoComm + 1));
  }
}

void PdoEngine::mapping_changed(unsigned tpdo_number, TimeUs now) {
  for (Tpdo& t : tpdos_)
    if (unsigned(t.cfg.comm_index - kTpdoComm + 1) == tpdo_number) after_config_change(t.cfg, true, 0, now);
  node_.rx_changed();
  update_deadline();
}

// Samples the mapped objects (live values through the application) into a frame.
bool PdoEngine::build(Tpdo& t, TimeUs now, CanFrame& out) {
  // An empty mapping sends nothing, unless the vendor sends DLC 0 frames for it.
  if (t.cfg.item_count == 0 && !(t.cfg.declared_empty && node_.options().tpdo_send_empty_mapping)) return false;
  out = CanFrame{};
  out.id = cob::can_id(t.cfg.cobid);
  if (t.cfg.cobid & kPdoCobFrame) out.flags = CanFrame::kExtended;
  unsigned at = 0;
  for (const PdoMapItem& item : std::span(t.cfg.items).first(t.cfg.item_count)) {
    const OdEntry& e = node_.od().entry(item.slot);
    node_.refresh(e, now);
    std::uint8_t value[8] = {};
    const auto bytes = node_.values().bytes(e);
    if (!bytes.empty()) std::memcpy(value, bytes.data(), std::min<std::size_t>(bytes.size(), sizeof value));
    put_bits(out.data, at, value, item.bits);
    at += item.bits;
  }
  out.dlc = node_.options().tpdo_dlc_always_8 ? 8 : std::uint8_t((at + 7) / 8);
  return true;
}

void PdoEngine::transmit(Tpdo& t, TimeUs now, TimeUs delay) {
  CanFrame f;
  if (!build(t, now, f)) return;
  node_.send_after(f, delay);
  t.last_sent = now;
}

void PdoEngine::on_rpdo(Rpdo& r, const CanFrame& frame, TimeUs now) {
  if (r.cfg.item_count == 0) return;
  const unsigned need = (r.cfg.bits + 7u) / 8u;
  // CiA 301 §7.2.2.1: too short → not processed, EMCY 0x8210; longer → the
  // mapped part is used, EMCY 0x8220. One EMCY per error episode.
  if (frame.dlc < need) {
    if (!r.short_reported) raise_emcy(node_.emcy(), emcy::kPdoLength, now);
    r.short_reported = true;
    return;
  }
  if (r.short_reported) clear_emcy(node_.emcy(), emcy::kPdoLength, now);
  r.short_reported = false;
  const bool too_long = frame.dlc > need && node_.options().rpdo_length_exceeded_emcy;
  if (too_long && !r.long_reported) raise_emcy(node_.emcy(), emcy::kPdoLengthExceeded, now);
  if (!too_long && r.long_reported) clear_emcy(node_.emcy(), emcy::kPdoLengthExceeded, now);
  r.long_reported = too_long;
  if (r.timed_out) clear_emcy(node_.emcy(), emcy::kRpdoTimeout, now);
  r.timed_out = false;
  if (r.cfg.event_ms) r.timeout_due = now + node_.local_duration(ms(r.cfg.event_ms));
  r.buffer = frame;
  if (r.cfg.type <= kTypeLastCyclic) {
    r.buffered = true;  // actuated at the next SYNC
  } else {
    apply(r, now);
  }
}

void PdoEngine::apply(Rpdo& r, TimeUs now) {
  r.buffered = false;
  unsigned at = 0;
  for (const PdoMapItem& item : std::span(r.cfg.items).first(r.cfg.item_count)) {
    if (item.slot != PdoMapItem::kDummy) {
      const OdEntry& e = node_.od().entry(item.slot);
      std::uint8_t value[8] = {};
      get_bits(value, r.buffer.data, at, item.bits);
      const std::size_t size = is_variable_size(e.type) ? item.bits / 8u : type_size(e.type);
      store_received(e, std::span<const std::uint8_t>(value, size), now);
    }
    at += item.bits;
  }
}

// RPDO data skips SDO access rules (the mapping was checked for writability)
// but keeps the value limits and the application's write hooks. The observer
// hears of each object stored.
void PdoEngine::store_received(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs now) {
  if (!ok(check_value(e, data))) return;
  Application* app = (e.hooks & kHookWrite) ? node_.app() : nullptr;
  if (app && !ok(app->check_write(node_, e, data, now))) return;
  node_.values().set_bytes(e, data);
  if (app) app->after_write(node_, e, now);
  if (NodeObserver* o = node_.observer()) o->on_remote_write(node_, e, WriteVia::kRpdo, now);
}

void PdoEngine::collect_rx_ids(std::vector<std::uint32_t>& out) const {
  for (const Rpdo& r : rpdos_)
    if (valid(r.cfg)) out.push_back(cob::rx_id(r.cfg.cobid));
  if (!node_.options().tpdo_rtr_supported) return;
  for (const Tpdo& t : tpdos_)
    if (valid(t.cfg) && !(t.cfg.cobid & kPdoCobNoRtr)) out.push_back(cob::rx_id(t.cfg.cobid));
}

// ---------------------------------------------------------------------------

void PdoEngine::update_deadline() {
  TimeUs next = kNever;
  if (running()) {
    for (std::uint16_t i : event_tpdos_) {
      const Tpdo& t = tpdos_[i];
      next = std::min(next, t.event_due);
      if (t.event_pending) next = std::min(next, t.inhibit_until);
    }
    for (std::uint16_t i : watched_rpdos_) next = std::min(next, rpdos_[i].timeout_due);
  }
  next_ = next;
}

TimeUs PdoEngine::next_deadline() const { return next_; }

}  // namespace cansim
