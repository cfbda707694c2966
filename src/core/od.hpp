// Object dictionary (CiA 301 §7.4): the layout (what objects exist, their type,
// access, limits and defaults) is immutable and shared by every node of a
// profile; each node owns only an OdValues byte store. One store serves SDO,
// PDO and the application.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/sdo_abort.hpp"

namespace cansim {

// CiA 301 Table 44 data type indices.
enum class DataType : std::uint8_t {
  kBoolean = 0x01,
  kInteger8 = 0x02,
  kInteger16 = 0x03,
  kInteger32 = 0x04,
  kUnsigned8 = 0x05,
  kUnsigned16 = 0x06,
  kUnsigned32 = 0x07,
  kReal32 = 0x08,
  kVisibleString = 0x09,
  kOctetString = 0x0A,
  kUnicodeString = 0x0B,
  kDomain = 0x0F,
  kInteger24 = 0x10,
  kReal64 = 0x11,
  kInteger40 = 0x12,
  kInteger48 = 0x13,
  kInteger56 = 0x14,
  kInteger64 = 0x15,
  kUnsigned24 = 0x16,
  kUnsigned40 = 0x18,
  kUnsigned48 = 0x19,
  kUnsigned56 = 0x1A,
  kUnsigned64 = 0x1B,
};

enum class Access : std::uint8_t { kRo, kWo, kRw, kRwr, kRww, kConst };
enum class ObjectKind : std::uint8_t { kVar = 0x07, kArray = 0x08, kRecord = 0x09 };

// Persistence group = the 0x1010/0x1011 sub-index that stores the entry:
// 0 not stored, 2 communication, 3 application, 4..127 manufacturer-defined.
// Sub 1 ("all") covers every group.
enum : std::uint8_t {
  kPersistNone = 0,
  kPersistCommunication = 2,
  kPersistApplication = 3,
};

// Entry flags telling the node to call the Application around accesses.
enum : std::uint8_t {
  kHookRead = 0x01,   // refresh the value before a remote read (live values)
  kHookWrite = 0x02,  // let the application check and react to remote writes
};

// Fixed byte size of a type, or 0 for variable-size types (strings, DOMAIN).
std::size_t type_size(DataType t);
bool is_signed(DataType t);
bool is_real(DataType t);
bool is_variable_size(DataType t);
const char* type_name(DataType t);
bool parse_type(std::string_view name, DataType& out);
bool parse_access(std::string_view name, Access& out);
const char* access_name(Access a);
inline bool readable(Access a) { return a != Access::kWo; }
inline bool writable(Access a) {
  return a == Access::kRw || a == Access::kWo || a == Access::kRwr || a == Access::kRww;
}

// One sub-index.
struct OdEntry {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  ObjectKind kind = ObjectKind::kVar;
  DataType type = DataType::kUnsigned8;
  Access access = Access::kRo;
  bool pdo_mappable = false;
  std::uint8_t persist = kPersistNone;
  std::uint8_t hooks = 0;
  std::uint32_t capacity = 0;  // bytes reserved (fixed size, or max length)
  std::string name;
  // Default value, little-endian encoded; for integer types `default_plus_node_id`
  // adds the node-ID at reset time ("$NODEID+0x180").
  std::vector<std::uint8_t> default_bytes;
  bool default_plus_node_id = false;
  bool has_low = false;
  bool has_high = false;
  std::uint8_t low[8] = {};
  std::uint8_t high[8] = {};

  // Filled in by OdLayout::finalize().
  std::uint32_t offset = 0;
  std::uint16_t slot = 0;
};

struct OdObject {
  std::uint16_t index = 0;
  ObjectKind kind = ObjectKind::kVar;
  std::string name;
  std::uint16_t first = 0;  // slot of its first entry
  std::uint16_t count = 0;  // number of entries (sub-indices present)
};

class OdLayout {
 public:
  // Adds an entry; returns false if (index, sub) already exists.
  bool add(OdEntry entry);
  // Sorts entries, assigns offsets and builds the lookup tables and the
  // default values (edits after it must not change defaults, types or sizes).
  void finalize();

  const OdEntry* find(std::uint16_t index, std::uint8_t sub) const;
  // A sub-index of a known object, without a hash lookup.
  const OdEntry* find(const OdObject& object, std::uint8_t sub) const;
  const OdObject* object(std::uint16_t index) const;
  // Like find(), but says why not: 0x06020000 (no object) or 0x06090011 (no sub).
  const OdEntry* lookup(std::uint16_t index, std::uint8_t sub, SdoAbort& why) const;

  std::span<const OdEntry> entries() const { return entries_; }
  std::span<const OdObject> objects() const { return objects_; }
  std::uint32_t value_bytes() const { return value_bytes_; }
  std::uint32_t max_capacity() const { return max_capacity_; }  // of the largest entry
  const OdEntry& entry(std::uint16_t slot) const { return entries_[slot]; }
  // The slots [first, second) of the entries whose index lies in [first, last]
  // (entries are sorted, so they are adjacent in slots and in value bytes).
  std::pair<std::size_t, std::size_t> slots(std::uint16_t first, std::uint16_t last) const;
  // Built by finalize(), so that a reset copies instead of encoding entry by
  // entry: every value at its default (a $NODEID default without the
  // node-ID), the size of each, and the slots whose default adds the node-ID.
  std::span<const std::uint8_t> default_values() const { return default_values_; }
  std::span<const std::uint32_t> default_sizes() const { return default_sizes_; }
  std::span<const std::uint16_t> node_id_slots() const { return node_id_slots_; }
  // Mutable access before finalize() (profile loading, personalities setting hooks).
  OdEntry* edit(std::uint16_t index, std::uint8_t sub);

 private:
  static std::uint32_t key(std::uint16_t index, std::uint8_t sub) { return (std::uint32_t(index) << 8) | sub; }
  void build_defaults();
  std::vector<OdEntry> entries_;
  std::vector<OdObject> objects_;
  std::unordered_map<std::uint32_t, std::uint16_t> by_key_;
  std::unordered_map<std::uint16_t, std::uint16_t> by_index_;
  std::uint32_t value_bytes_ = 0;
  std::uint32_t max_capacity_ = 0;
  std::vector<std::uint8_t> default_values_;
  std::vector<std::uint32_t> default_sizes_;
  std::vector<std::uint16_t> node_id_slots_;
  bool final_ = false;
};

// Checks a value about to be written: length against the type
// (0x06070010/12/13) and against low/high limits (0x06090031/32).
SdoAbort check_value(const OdEntry& e, std::span<const std::uint8_t> data);

// A node's values. All accessors take the entry (cache OdEntry pointers at
// init; index lookups are for tests and set-up code).
class OdValues {
 public:
  OdValues() = default;
  explicit OdValues(std::shared_ptr<const OdLayout> layout);

  const OdLayout& layout() const { return *layout_; }

  // Resets entries whose index lies in [first, last] to their defaults.
  void reset(std::uint8_t node_id, std::uint16_t first = 0x0000, std::uint16_t last = 0xFFFF);

  std::span<const std::uint8_t> bytes(const OdEntry& e) const { return {data_.data() + e.offset, sizes_[e.slot]}; }
  // Stores raw bytes (no checks; truncated to capacity).
  void set_bytes(const OdEntry& e, std::span<const std::uint8_t> v);

  // Numeric views, converting from / to the entry's own type.
  std::uint64_t get_u(const OdEntry& e) const;
  std::int64_t get_i(const OdEntry& e) const;
  double get_f(const OdEntry& e) const;
  void set_u(const OdEntry& e, std::uint64_t v);
  void set_i(const OdEntry& e, std::int64_t v);
  void set_f(const OdEntry& e, double v);
  std::string_view get_string(const OdEntry& e) const;
  void set_string(const OdEntry& e, std::string_view s);

  // Convenience by index (hash lookup); returns 0 / false when absent.
  std::uint64_t u(std::uint16_t index, std::uint8_t sub) const;
  bool set_u(std::uint16_t index, std::uint8_t sub, std::uint64_t v);

  std::size_t memory_bytes() const { return data_.capacity() + sizes_.capacity() * 4; }

 private:
  std::shared_ptr<const OdLayout> layout_;
  std::vector<std::uint8_t> data_;
  std::vector<std::uint32_t> sizes_;
};

// Little-endian encoding of numbers in a numeric type (type_size(t) bytes).
void encode_u(DataType t, std::uint64_t v, std::uint8_t* out);
void encode_i(DataType t, std::int64_t v, std::uint8_t* out);
void encode_f(DataType t, double v, std::uint8_t* out);
std::uint64_t decode_u(DataType t, const std::uint8_t* p);
std::int64_t decode_i(DataType t, const std::uint8_t* p);
double decode_f(DataType t, const std::uint8_t* p);

}  // namespace cansim
