#include "core/store.hpp"

#include <cstring>

#include "core/crc32.hpp"
#include "core/node.hpp"

namespace cansim {

namespace {
constexpr std::uint8_t kMagic[4] = {'C', 'S', 'N', 'V'};
constexpr std::uint8_t kVersion = 1;
constexpr std::size_t kHeaderSize = 10;   // magic, version, LSS (3), record count u16
constexpr std::size_t kRecordHeader = 6;  // index u16, sub, group, length u16
constexpr std::size_t kCrcSize = 4;
constexpr std::uint8_t kAllGroups = 1;

// 0x1010/0x1011 sub 1 covers every group, the others their own (od.hpp).
bool in_group(std::uint8_t sub, std::uint8_t group) { return group != 0 && (sub == kAllGroups || sub == group); }

bool blob_ok(std::span<const std::uint8_t> b) {
  if (b.size() < kHeaderSize + kCrcSize) return false;
  if (std::memcmp(b.data(), kMagic, 4) != 0 || b[4] != kVersion) return false;
  std::size_t body = b.size() - kCrcSize;
  if (crc32(b.first(body)) != get_u32(b.data() + body)) return false;
  std::size_t pos = kHeaderSize;
  for (unsigned n = get_u16(b.data() + 8); n > 0; --n) {
    if (pos + kRecordHeader > body) return false;
    pos += kRecordHeader + get_u16(b.data() + pos + 4);
  }
  return pos == body;
}

// Why a loaded blob cannot be used, or nullptr.
const char* blob_defect(std::span<const std::uint8_t> b) {
  if (!blob_ok(b)) return "stored parameters with a bad magic, version, length or CRC";
  // CiA 305: LSS stores a node-ID 1..127 or 0xFF (unconfigured); 0 would send on 0x700.
  const std::uint8_t id = b[6];
  if (b[5] != 0 && !(id >= 1 && id <= 127) && id != 0xFF) return "stored parameters with an LSS node-ID outside 1..127";
  return nullptr;
}

void append_u16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(std::uint8_t(v));
  out.push_back(std::uint8_t(v >> 8));
}

void append_record(std::vector<std::uint8_t>& out, std::uint16_t index, std::uint8_t sub, std::uint8_t group,
                   std::span<const std::uint8_t> bytes) {
  append_u16(out, index);
  out.push_back(sub);
  out.push_back(group);
  append_u16(out, std::uint16_t(bytes.size()));
  out.insert(out.end(), bytes.begin(), bytes.end());
}

}  // namespace

// Loads into the cache itself: no allocation once it has held a blob this long.
void StoreRestore::load() {
  blob_.clear();
  lss_ = LssStored{};
  corrupt_ = false;
  NodeStorage* storage = node_.storage();
  if (!storage || !storage->load(blob_) || blob_.empty()) {
    blob_.clear();
    return;
  }
  if (const char* bad = blob_defect(blob_)) {
    blob_.clear();
    corrupt_ = true;
    storage->rejected(bad);
    return;
  }
  lss_.valid = blob_[5] != 0;
  lss_.node_id = blob_[6];
  lss_.bit_rate_index = blob_[7];
}

template <typename Fn>
void StoreRestore::for_each_record(Fn&& fn) const {
  if (blob_.empty()) return;
  std::size_t pos = kHeaderSize;
  for (unsigned n = get_u16(blob_.data() + 8); n > 0; --n) {
    const std::uint8_t* p = blob_.data() + pos;
    std::uint16_t len = get_u16(p + 4);
    fn(Record{get_u16(p), p[2], p[3], {p + kRecordHeader, len}});
    pos += kRecordHeader + len;
  }
}

// Robust to a changed profile: records for entries that vanished, stopped
// being persistent or changed size are skipped.
void StoreRestore::apply_stored(std::uint16_t first, std::uint16_t last) {
  for_each_record([&](const Record& r) {
    if (r.index < first || r.index > last) return;
    const OdEntry* e = node_.od().find(r.index, r.sub);
    if (!e || e->persist == kPersistNone) return;
    std::size_t fixed = type_size(e->type);
    if (fixed ? r.bytes.size() != fixed : r.bytes.size() > e->capacity) return;
    node_.values().set_bytes(*e, r.bytes);
  });
}

bool StoreRestore::rewrite(std::uint8_t drop_sub, bool add_current, std::span<const OdEntry* const> entries) {
  auto listed = [&](std::uint16_t index, std::uint8_t sub) {
    for (const OdEntry* e : entries)
      if (e->index == index && e->sub == sub) return true;
    return false;
  };
  std::vector<std::uint8_t> out(kMagic, kMagic + 4);
  out.push_back(kVersion);
  out.push_back(lss_.valid ? 1 : 0);
  out.push_back(lss_.node_id);
  out.push_back(lss_.bit_rate_index);
  append_u16(out, 0);
  unsigned count = 0;
  for_each_record([&](const Record& r) {
    if (in_group(drop_sub, r.group) || listed(r.index, r.sub)) return;
    append_record(out, r.index, r.sub, r.group, r.bytes);
    ++count;
  });
  if (add_current) {
    for (const OdEntry& e : node_.od().entries()) {
      if (!in_group(drop_sub, e.persist) || listed(e.index, e.sub) || holds_node_id_default(e)) continue;
      append_record(out, e.index, e.sub, e.persist, node_.values().bytes(e));
      ++count;
    }
  }
  for (const OdEntry* e : entries) {
    append_record(out, e->index, e->sub, e->persist, node_.values().bytes(*e));
    ++count;
  }
  put_u16(out.data() + 8, std::uint16_t(count));
  std::uint32_t crc = crc32(out);
  out.resize(out.size() + kCrcSize);
  put_u32(out.data() + out.size() - kCrcSize, crc);
  NodeStorage* storage = node_.storage();
  if (!storage || !storage->save(out)) return false;
  blob_ = std::move(out);
  corrupt_ = false;
  return true;
}

SdoAbort StoreRestore::save_group(std::uint8_t sub) {
  return rewrite(sub, true) ? SdoAbort::kNone : SdoAbort::kHardware;
}

SdoAbort StoreRestore::restore_group(std::uint8_t sub) {
  const RestoreMode mode = node_.options().restore_mode;
  if (mode == RestoreMode::kRam) {
    defaults_to_ram(sub);  // kept only if saved afterwards
    return SdoAbort::kNone;
  }
  if (!rewrite(sub, false)) return SdoAbort::kHardware;
  if (mode == RestoreMode::kImmediate) defaults_to_ram(sub);
  return SdoAbort::kNone;
}

// Vendor variants: the defaults of the group replace the RAM values now
// (services pick them up at their next reset).
void StoreRestore::defaults_to_ram(std::uint8_t sub) {
  std::uint16_t last_index = 0;
  bool any = false;
  for (const OdEntry& e : node_.od().entries()) {
    if (!in_group(sub, e.persist) || (any && e.index == last_index)) continue;
    node_.values().reset(node_.node_id(), e.index, e.index);
    last_index = e.index;
    any = true;
  }
}

bool StoreRestore::holds_node_id_default(const OdEntry& e) const {
  if (!e.default_plus_node_id || e.default_bytes.size() != type_size(e.type) || is_variable_size(e.type)) return false;
  return node_.values().get_u(e) == decode_u(e.type, e.default_bytes.data()) + node_.default_node_id();
}

bool StoreRestore::save_entries(std::span<const OdEntry* const> entries) { return rewrite(0, false, entries); }

bool StoreRestore::stored_u(const OdEntry& e, std::uint64_t& out) const {
  bool found = false;
  for_each_record([&](const Record& r) {
    if (r.index != e.index || r.sub != e.sub || r.bytes.size() != type_size(e.type) || is_variable_size(e.type)) return;
    out = decode_u(e.type, r.bytes.data());
    found = true;
  });
  return found;
}

bool StoreRestore::save_lss(const LssStored& lss) {
  LssStored old = lss_;
  lss_ = lss;
  if (rewrite(0, false)) return true;
  lss_ = old;
  return false;
}

void StoreRestore::reset(TimeUs) { next_ = kNever; }
bool StoreRestore::on_frame(const CanFrame&, TimeUs) { return false; }
void StoreRestore::process(TimeUs) { next_ = kNever; }
void StoreRestore::collect_rx_ids(std::vector<std::uint32_t>&) const {}
bool StoreRestore::owns(std::uint16_t index) const { return index == 0x1010 || index == 0x1011; }

// The written signature is a command, never stored: reads keep returning the
// capability bits (CiA 301 §7.5.2.13).
SdoAbort StoreRestore::write(const OdEntry& e, std::span<const std::uint8_t> data, TimeUs) {
  if (e.sub == 0) return SdoAbort::kReadOnly;
  std::uint32_t v = std::uint32_t(decode_u(e.type, data.data()));
  bool save = e.index == 0x1010;
  if (v != (save ? kSave : kLoad)) return SdoAbort(std::uint32_t(node_.options().store_bad_signature_abort));
  return save ? save_group(e.sub) : restore_group(e.sub);
}

}  // namespace cansim
