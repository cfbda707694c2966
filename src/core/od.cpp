#include "core/od.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

namespace cansim {

namespace {

struct TypeInfo {
  DataType type;
  const char* name;
  std::uint8_t size;
  bool is_signed;
  bool is_real;
};

constexpr TypeInfo kTypes[] = {
    {DataType::kBoolean, "BOOLEAN", 1, false, false},
    {DataType::kInteger8, "INTEGER8", 1, true, false},
    {DataType::kInteger16, "INTEGER16", 2, true, false},
    {DataType::kInteger24, "INTEGER24", 3, true, false},
    {DataType::kInteger32, "INTEGER32", 4, true, false},
    {DataType::kInteger40, "INTEGER40", 5, true, false},
    {DataType::kInteger48, "INTEGER48", 6, true, false},
    {DataType::kInteger56, "INTEGER56", 7, true, false},
    {DataType::kInteger64, "INTEGER64", 8, true, false},
    {DataType::kUnsigned8, "UNSIGNED8", 1, false, false},
    {DataType::kUnsigned16, "UNSIGNED16", 2, false, false},
    {DataType::kUnsigned24, "UNSIGNED24", 3, false, false},
    {DataType::kUnsigned32, "UNSIGNED32", 4, false, false},
    {DataType::kUnsigned40, "UNSIGNED40", 5, false, false},
    {DataType::kUnsigned48, "UNSIGNED48", 6, false, false},
    {DataType::kUnsigned56, "UNSIGNED56", 7, false, false},
    {DataType::kUnsigned64, "UNSIGNED64", 8, false, false},
    {DataType::kReal32, "REAL32", 4, true, true},
    {DataType::kReal64, "REAL64", 8, true, true},
    {DataType::kVisibleString, "VISIBLE_STRING", 0, false, false},
    {DataType::kOctetString, "OCTET_STRING", 0, false, false},
    {DataType::kUnicodeString, "UNICODE_STRING", 0, false, false},
    {DataType::kDomain, "DOMAIN", 0, false, false},
};

// kTypes by type index: type_size() and friends sit on every OD access and
// every reset of every entry, so they index instead of searching.
constexpr std::size_t kTypeIndices = 0x20;  // CiA 301 Table 44 indices in use are below this
constexpr std::array<const TypeInfo*, kTypeIndices> kByIndex = [] {
  std::array<const TypeInfo*, kTypeIndices> by_index{};
  for (const auto& i : kTypes) by_index[std::size_t(i.type)] = &i;
  return by_index;
}();

const TypeInfo* info(DataType t) {
  const auto i = std::size_t(t);
  return i < kTypeIndices ? kByIndex[i] : nullptr;
}

constexpr const char* kAccessNames[] = {"ro", "wo", "rw", "rwr", "rww", "const"};

}  // namespace

std::size_t type_size(DataType t) {
  const TypeInfo* i = info(t);
  return i ? i->size : 0;
}
bool is_signed(DataType t) {
  const TypeInfo* i = info(t);
  return i && i->is_signed;
}
bool is_real(DataType t) { return t == DataType::kReal32 || t == DataType::kReal64; }
bool is_variable_size(DataType t) { return type_size(t) == 0; }
const char* type_name(DataType t) {
  const TypeInfo* i = info(t);
  return i ? i->name : "?";
}
bool parse_type(std::string_view name, DataType& out) {
  for (const auto& i : kTypes) {
    if (name == i.name) {
      out = i.type;
      return true;
    }
  }
  if (name == "UNICODE") {
    out = DataType::kUnicodeString;
    return true;
  }
  return false;
}
bool parse_access(std::string_view name, Access& out) {
  for (int i = 0; i < 6; ++i) {
    if (name == kAccessNames[i]) {
      out = Access(i);
      return true;
    }
  }
  return false;
}
const char* access_name(Access a) { return kAccessNames[int(a)]; }

namespace {
std::uint64_t get_bits(const std::uint8_t* p, int n) {
  std::uint64_t v = 0;
  for (int b = 0; b < n; ++b) v |= std::uint64_t(p[b]) << (8 * b);
  return v;
}
}  // namespace

void encode_u(DataType t, std::uint64_t v, std::uint8_t* out) {
  if (t == DataType::kReal32 || t == DataType::kReal64) return encode_f(t, double(v), out);
  for (std::size_t b = 0; b < type_size(t); ++b) out[b] = std::uint8_t(v >> (8 * b));
}
void encode_i(DataType t, std::int64_t v, std::uint8_t* out) {
  if (is_real(t)) return encode_f(t, double(v), out);
  encode_u(t, std::uint64_t(v), out);
}
void encode_f(DataType t, double v, std::uint8_t* out) {
  if (t == DataType::kReal32) {
    std::uint32_t bits = std::bit_cast<std::uint32_t>(float(v));
    for (int b = 0; b < 4; ++b) out[b] = std::uint8_t(bits >> (8 * b));
  } else if (t == DataType::kReal64) {
    std::uint64_t bits = std::bit_cast<std::uint64_t>(v);
    for (int b = 0; b < 8; ++b) out[b] = std::uint8_t(bits >> (8 * b));
  } else if (is_signed(t)) {
    encode_i(t, std::int64_t(std::llround(v)), out);
  } else {
    encode_u(t, v <= 0 ? 0 : std::uint64_t(std::llround(v)), out);
  }
}
// A REAL read as an integer saturates at the integer's bounds (NaN reads 0):
// never a cast out of range (UB), whatever a master wrote.
namespace {
template <typename I>
I saturate(double x) {
  if (!(x == x)) return 0;
  if (x <= double(std::numeric_limits<I>::min())) return std::numeric_limits<I>::min();
  if (x >= double(std::numeric_limits<I>::max())) return std::numeric_limits<I>::max();
  return I(x);
}
}  // namespace
std::uint64_t decode_u(DataType t, const std::uint8_t* p) {
  if (is_real(t)) return saturate<std::uint64_t>(decode_f(t, p));
  std::uint64_t v = 0;
  std::size_t n = type_size(t);
  for (std::size_t b = 0; b < n; ++b) v |= std::uint64_t(p[b]) << (8 * b);
  return v;
}
std::int64_t decode_i(DataType t, const std::uint8_t* p) {
  if (is_real(t)) return saturate<std::int64_t>(decode_f(t, p));
  std::uint64_t v = decode_u(t, p);
  std::size_t n = type_size(t);
  if (is_signed(t) && n < 8 && n > 0 && (v >> (8 * n - 1)) & 1) v |= ~0ULL << (8 * n);
  return std::int64_t(v);
}
double decode_f(DataType t, const std::uint8_t* p) {
  if (t == DataType::kReal32) return std::bit_cast<float>(std::uint32_t(get_bits(p, 4)));
  if (t == DataType::kReal64) return std::bit_cast<double>(get_bits(p, 8));
  return is_signed(t) ? double(decode_i(t, p)) : double(decode_u(t, p));
}

// ---------------------------------------------------------------- OdLayout

bool OdLayout::add(OdEntry entry) {
  if (final_) return false;
  std::uint32_t k = key(entry.index, entry.sub);
  for (const auto& e : entries_)
    if (key(e.index, e.sub) == k) return false;
  if (entry.capacity == 0) entry.capacity = std::uint32_t(type_size(entry.type));
  entries_.push_back(std::move(entry));
  return true;
}

OdEntry* OdLayout::edit(std::uint16_t index, std::uint8_t sub) {
  for (auto& e : entries_)
    if (e.index == index && e.sub == sub) return &e;
  return nullptr;
}

void OdLayout::finalize() {
  std::sort(entries_.begin(), entries_.end(),
            [](const OdEntry& a, const OdEntry& b) { return key(a.index, a.sub) < key(b.index, b.sub); });
  objects_.clear();
  by_key_.clear();
  by_index_.clear();
  max_capacity_ = 0;
  std::uint32_t offset = 0;
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    OdEntry& e = entries_[i];
    e.slot = std::uint16_t(i);
    e.offset = offset;
    offset += (e.capacity + 7u) & ~7u;  // keep 8-byte alignment of every value
    max_capacity_ = std::max(max_capacity_, e.capacity);
    by_key_[key(e.index, e.sub)] = std::uint16_t(i);
    if (objects_.empty() || objects_.back().index != e.index) {
      by_index_[e.index] = std::uint16_t(objects_.size());
      objects_.push_back(OdObject{e.index, e.kind, e.name, std::uint16_t(i), 0});
    }
    objects_.back().count++;
  }
  value_bytes_ = offset;
  build_defaults();
  final_ = true;
}

void OdLayout::build_defaults() {
  default_values_.assign(value_bytes_, 0);
  default_sizes_.assign(entries_.size(), 0);
  node_id_slots_.clear();
  for (const OdEntry& e : entries_) {
    const std::size_t n = std::min<std::size_t>(e.default_bytes.size(), e.capacity);
    if (n) std::memcpy(default_values_.data() + e.offset, e.default_bytes.data(), n);
    const bool fixed_size = type_size(e.type) != 0;
    default_sizes_[e.slot] = std::uint32_t(fixed_size ? e.capacity : n);
    if (fixed_size && e.default_plus_node_id && !is_real(e.type)) node_id_slots_.push_back(e.slot);
  }
}

std::pair<std::size_t, std::size_t> OdLayout::slots(std::uint16_t first, std::uint16_t last) const {
  auto below = [](std::uint16_t bound) { return [bound](const OdEntry& e) { return e.index < bound; }; };
  const auto begin = std::partition_point(entries_.begin(), entries_.end(), below(first));
  const auto end = last == 0xFFFF ? entries_.end() : std::partition_point(begin, entries_.end(), below(last + 1));
  return {std::size_t(begin - entries_.begin()), std::size_t(end - entries_.begin())};
}

const OdEntry* OdLayout::find(std::uint16_t index, std::uint8_t sub) const {
  auto it = by_key_.find(key(index, sub));
  return it == by_key_.end() ? nullptr : &entries_[it->second];
}

// An object's entries are sorted by sub-index; most objects have every
// sub-index from 0, so entry `sub` is usually the one.
const OdEntry* OdLayout::find(const OdObject& object, std::uint8_t sub) const {
  const auto begin = entries_.begin() + object.first;
  const auto end = begin + object.count;
  if (sub < object.count && begin[sub].sub == sub) return &begin[sub];
  const auto it = std::partition_point(begin, end, [sub](const OdEntry& e) { return e.sub < sub; });
  return it != end && it->sub == sub ? &*it : nullptr;
}

const OdObject* OdLayout::object(std::uint16_t index) const {
  auto it = by_index_.find(index);
  return it == by_index_.end() ? nullptr : &objects_[it->second];
}

const OdEntry* OdLayout::lookup(std::uint16_t index, std::uint8_t sub, SdoAbort& why) const {
  if (const OdEntry* e = find(index, sub)) return e;
  why = object(index) ? SdoAbort::kNoSubIndex : SdoAbort::kNoObject;
  return nullptr;
}

// ---------------------------------------------------------------- checks

namespace {
int compare(DataType t, const std::uint8_t* a, const std::uint8_t* b) {
  if (is_real(t)) {
    double x = decode_f(t, a), y = decode_f(t, b);
    return x < y ? -1 : x > y ? 1 : 0;
  }
  if (is_signed(t)) {
    std::int64_t x = decode_i(t, a), y = decode_i(t, b);
    return x < y ? -1 : x > y ? 1 : 0;
  }
  std::uint64_t x = decode_u(t, a), y = decode_u(t, b);
  return x < y ? -1 : x > y ? 1 : 0;
}
}  // namespace

SdoAbort check_value(const OdEntry& e, std::span<const std::uint8_t> data) {
  std::size_t fixed = type_size(e.type);
  if (fixed) {
    if (data.size() > fixed) return SdoAbort::kLengthTooHigh;
    if (data.size() < fixed) return SdoAbort::kLengthTooLow;
    if (e.type == DataType::kBoolean && data[0] > 1) return SdoAbort::kInvalidValue;
    if (e.has_low && compare(e.type, data.data(), e.low) < 0) return SdoAbort::kValueTooLow;
    if (e.has_high && compare(e.type, data.data(), e.high) > 0) return SdoAbort::kValueTooHigh;
    return SdoAbort::kNone;
  }
  if (data.size() > e.capacity) return SdoAbort::kLengthTooHigh;
  return SdoAbort::kNone;
}

// ---------------------------------------------------------------- OdValues

OdValues::OdValues(std::shared_ptr<const OdLayout> layout) : layout_(std::move(layout)) {
  data_.assign(layout_->value_bytes(), 0);
  sizes_.assign(layout_->entries().size(), 0);
}

// The layout's default image over the entries' byte range (padding between
// values is zero in both), then the node-ID added to the $NODEID defaults.
void OdValues::reset(std::uint8_t node_id, std::uint16_t first, std::uint16_t last) {
  const auto [begin, end] = layout_->slots(first, last);
  if (begin == end) return;
  const std::size_t from = layout_->entry(std::uint16_t(begin)).offset;
  const std::size_t to = end < sizes_.size() ? layout_->entry(std::uint16_t(end)).offset : data_.size();
  std::memcpy(data_.data() + from, layout_->default_values().data() + from, to - from);
  std::memcpy(sizes_.data() + begin, layout_->default_sizes().data() + begin, (end - begin) * sizeof(sizes_[0]));
  for (std::uint16_t slot : layout_->node_id_slots()) {
    if (slot < begin || slot >= end) continue;
    const OdEntry& e = layout_->entry(slot);
    std::uint8_t* p = data_.data() + e.offset;
    encode_u(e.type, decode_u(e.type, p) + node_id, p);
  }
}

void OdValues::set_bytes(const OdEntry& e, std::span<const std::uint8_t> v) {
  std::size_t n = std::min<std::size_t>(v.size(), e.capacity);
  if (n) std::memcpy(data_.data() + e.offset, v.data(), n);
  sizes_[e.slot] = std::uint32_t(type_size(e.type) ? e.capacity : n);
}

std::uint64_t OdValues::get_u(const OdEntry& e) const { return decode_u(e.type, data_.data() + e.offset); }
std::int64_t OdValues::get_i(const OdEntry& e) const { return decode_i(e.type, data_.data() + e.offset); }
double OdValues::get_f(const OdEntry& e) const { return decode_f(e.type, data_.data() + e.offset); }
void OdValues::set_u(const OdEntry& e, std::uint64_t v) { encode_u(e.type, v, data_.data() + e.offset); }
void OdValues::set_i(const OdEntry& e, std::int64_t v) { encode_i(e.type, v, data_.data() + e.offset); }
void OdValues::set_f(const OdEntry& e, double v) { encode_f(e.type, v, data_.data() + e.offset); }

std::string_view OdValues::get_string(const OdEntry& e) const {
  auto b = bytes(e);
  return {reinterpret_cast<const char*>(b.data()), b.size()};
}
void OdValues::set_string(const OdEntry& e, std::string_view s) {
  set_bytes(e, {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()});
}

std::uint64_t OdValues::u(std::uint16_t index, std::uint8_t sub) const {
  const OdEntry* e = layout_->find(index, sub);
  return e ? get_u(*e) : 0;
}
bool OdValues::set_u(std::uint16_t index, std::uint8_t sub, std::uint64_t v) {
  const OdEntry* e = layout_->find(index, sub);
  if (!e) return false;
  set_u(*e, v);
  return true;
}

}  // namespace cansim
