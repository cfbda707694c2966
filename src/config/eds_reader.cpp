#include "config/eds_reader.hpp"

#include "config/limits.hpp"
#include "config/printable.hpp"
#include "config/strict_mode.hpp"
#include "core/protocol.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <unordered_map>

namespace cansim::config {

namespace {

// Lower case without blanks: how section names and keys are compared.
std::string normalized(std::string_view s) {
  std::string out;
  for (char c : s)
    if (c != ' ' && c != '\t') out += char(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string_view trimmed(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool is_hex(std::string_view s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
}

std::string message_at(const std::string& file, int line, const std::string& where, const std::string& expected,
                       const std::string* got = nullptr) {
  std::string msg = file + ":" + std::to_string(line) + ": " + printable(where) + ": " + printable(expected);
  if (got) msg += ", got '" + printable(*got) + "'";
  return msg;
}

[[noreturn]] void reject(const std::string& file, int line, const std::string& where, const std::string& expected,
                         const std::string* got = nullptr) {
  throw ConfigError(message_at(file, line, where, expected, got));
}

// ---------------------------------------------------------------- lines

class LineParser {
 public:
  LineParser(const std::string& text, std::string file) : text_(text) { doc_.file = std::move(file); }

  EdsDocument run() {
    std::size_t at = 0;
    int line = 0;
    while (at < text_.size()) {
      std::size_t end = text_.find('\n', at);
      if (end == std::string::npos) end = text_.size();
      ++line;
      std::string_view raw(text_.data() + at, end - at);
      if (line == 1 && raw.substr(0, 3) == "\xEF\xBB\xBF") raw.remove_prefix(3);  // UTF-8 BOM
      if (!raw.empty() && raw.back() == '\r') raw.remove_suffix(1);
      while (!raw.empty() && (raw.front() == ' ' || raw.front() == '\t')) raw.remove_prefix(1);
      handle(raw, line);  // trailing blanks stay: they may belong to a string value
      at = end + 1;
    }
    return std::move(doc_);
  }

 private:
  void handle(std::string_view s, int line) {
    if (trimmed(s).empty() || s.front() == ';' || s.front() == '#') return;
    if (s.front() == '[') return open_section(s, line);
    const std::size_t eq = s.find('=');
    if (eq == std::string_view::npos || trimmed(s.substr(0, eq)).empty()) {
      std::string got(trimmed(s));
      reject(doc_.file, line, current_name(), "expected [section], key=value or a ; comment", &got);
    }
    if (doc_.sections.empty()) {
      std::string got(trimmed(s));
      reject(doc_.file, line, "(before the first section)", "expected a [section] before any key", &got);
    }
    std::string_view text = s.substr(eq + 1);
    const bool spaced = eq > 0 && (s[eq - 1] == ' ' || s[eq - 1] == '\t');
    while (spaced && !text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
    EdsKey k{std::string(trimmed(s.substr(0, eq))), std::string(trimmed(text)), std::string(text), line, {}};
    k.key = normalized(k.name);
    EdsSection& sec = doc_.sections.back();
    if (const auto [first, fresh] = key_lines_.emplace(k.key, line); !fresh)
      reject(doc_.file, line, "[" + sec.name + "] " + k.name,
             "expected each key once per section (first at line " + std::to_string(first->second) + ")");
    sec.keys.push_back(std::move(k));
  }

  void open_section(std::string_view s, int line) {
    const std::size_t close = s.find(']');
    std::string_view after = close == std::string_view::npos ? "" : trimmed(s.substr(close + 1));
    if (close == std::string_view::npos || trimmed(s.substr(1, close - 1)).empty() ||
        (!after.empty() && after.front() != ';')) {
      std::string got(trimmed(s));
      reject(doc_.file, line, current_name(), "expected a section header [name]", &got);
    }
    EdsSection sec{std::string(trimmed(s.substr(1, close - 1))), line, {}, {}};
    sec.key = normalized(sec.name);
    if (const auto [first, fresh] = section_lines_.emplace(sec.key, line); !fresh)
      reject(doc_.file, line, "[" + sec.name + "]",
             "expected each section once (first at line " + std::to_string(first->second) + ")");
    key_lines_.clear();
    doc_.sections.push_back(std::move(sec));
  }

  std::string current_name() const {
    return doc_.sections.empty() ? "(before the first section)" : "[" + doc_.sections.back().name + "]";
  }

  const std::string& text_;
  EdsDocument doc_;
  std::unordered_map<std::string, int> section_lines_;  // normalized name -> line
  std::unordered_map<std::string, int> key_lines_;      // of the current section
};

// ---------------------------------------------------------------- values

// What real masters repair or ignore in a file, one kind each (docs/eds-dbc.md,
// "Device descriptions": what is tolerated). Each loads with one warning per
// kind per file naming its first place; `cansimd --strict-eds` refuses them.
enum class Repair {
  kSdoServerCobId,      // 0x1200:01/02 other than 600h / 580h + node-ID (CiA 301 §7.2.4.3.2)
  kDomainZero,          // DOMAIN DefaultValue=0
  kUnsetCommissioning,  // [DeviceComissioning] NodeID=0 / Baudrate=0: CANopenEditor's "not set"
  kListedMissing,       // an [...Objects] entry without its section
  kObjectCount,         // SupportedObjects other than the keys 1..n
  kSubNumber,           // SubNumber other than the [xxxxsubN] sections
  kRealBits,            // a REAL written as its IEEE 754 bits (0x3E6B851F)
  kNodeIdLimit,         // $NODEID in LowLimit / HighLimit
  kUnknownDataType,     // a manufacturer complex or other non-basic DataType (0x0020-0x025F): an empty DOMAIN
  kNoSubObjects,        // an ARRAY / RECORD without [xxxxsubN] sections or CompactSubObj: no entries
  kCount
};

// The repairs of one file: the first of each kind as a warning, the others counted.
class Repairs {
 public:
  explicit Repairs(bool strict) : strict_(strict) {}
  bool strict() const { return strict_; }
  void note(Repair kind, int line, std::string message) {
    Seen& s = seen_[std::size_t(kind)];
    if (s.first.empty()) {
      s.first = std::move(message);
      s.line = line;
    } else {
      ++s.more;
    }
  }
  // In the order of their lines in the file.
  std::vector<std::string> warnings() const {
    std::vector<const Seen*> order;
    for (const Seen& s : seen_)
      if (!s.first.empty()) order.push_back(&s);
    std::stable_sort(order.begin(), order.end(), [](const Seen* a, const Seen* b) { return a->line < b->line; });
    std::vector<std::string> out;
    for (const Seen* s : order) {
      out.push_back(s->first);
      if (s->more) out.back() += " (and " + std::to_string(s->more) + " more like it in this file)";
    }
    return out;
  }

 private:
  struct Seen {
    std::string first;
    int line = 0;
    int more = 0;
  };
  bool strict_;
  std::array<Seen, std::size_t(Repair::kCount)> seen_;
};

// The file being read and its repairs.
struct Source {
  const EdsDocument& doc;
  Repairs& repairs;
};

// A key of a section, with what the error messages need.
struct Field {
  const Source* src = nullptr;
  const EdsSection* section = nullptr;
  const EdsKey* key = nullptr;  // null: absent
  std::string name;             // as the caller asked for it

  explicit operator bool() const { return key != nullptr; }
  const std::string& value() const { return key->value; }
  // Absent, or written without a value ("ParameterValue="): not given.
  bool empty() const { return !key || key->value.empty(); }
  std::string message(const std::string& expected) const {
    if (!key) return message_at(src->doc.file, section->line, "[" + section->name + "] " + name, expected);
    return message_at(src->doc.file, key->line, "[" + section->name + "] " + key->name, expected, &key->value);
  }
  [[noreturn]] void fail(const std::string& expected) const { throw ConfigError(message(expected)); }
  // What a master repairs: an error in strict mode (--strict-eds), else a
  // warning "<the error>; <what was done>".
  void tolerate(Repair kind, const std::string& expected, const std::string& done) const {
    if (src->repairs.strict()) fail(expected);
    src->repairs.note(kind, key ? key->line : section->line, message(expected) + "; " + done);
  }
};

Field field(const Source& src, const EdsSection& s, const char* name) { return Field{&src, &s, s.find(name), name}; }

// Strips a trailing "; comment" from a numeric field.
std::string numeric_text(const std::string& v) {
  return std::string(trimmed(std::string_view(v).substr(0, v.find(';'))));
}

// A sum of integer terms, at most one of them $NODEID (any case, any order).
bool parse_node_id_sum(const std::string& text, std::int64_t& value, bool& plus_node_id) {
  std::string s;
  for (char c : text)
    if (c != ' ' && c != '\t') s += c;
  value = 0;
  plus_node_id = false;
  if (s.empty()) return false;
  std::size_t start = 0;
  while (true) {
    std::size_t end = s.find('+', start == 0 && s[0] == '+' ? 1 : start);
    if (end == std::string::npos) end = s.size();
    const std::string term = s.substr(start, end - start);
    if (normalized(term) == "$nodeid") {
      if (plus_node_id) return false;
      plus_node_id = true;
    } else {
      std::int64_t v = 0;
      if (!parse_eds_integer(term, v) || __builtin_add_overflow(value, v, &value)) return false;
    }
    if (end == s.size()) return true;
    start = end + 1;
  }
}

std::int64_t get_integer(const Field& f, std::int64_t lo, std::int64_t hi) {
  std::int64_t v = 0;
  if (!parse_eds_integer(numeric_text(f.value()), v) || v < lo || v > hi)
    f.fail("expected an integer in " + std::to_string(lo) + ".." + std::to_string(hi) +
           " (decimal, 0x hex or 0 octal)");
  return v;
}

// A flag (PDOMapping, LSS_Supported, BaudRate_x, DummyXXXX) in any number
// form ("0x1", "01") or as true / false.
bool get_flag(const Field& f) {
  const std::string v = normalized(numeric_text(f.value()));
  if (v == "true") return true;
  if (v == "false") return false;
  std::int64_t n = -1;
  if (!parse_eds_integer(v, n) || (n != 0 && n != 1)) f.fail("expected 0 or 1");
  return n == 1;
}

// Hex bytes "0A0B" or "0A 0B" (OCTET_STRING, DOMAIN).
std::vector<std::uint8_t> get_hex_bytes(const Field& f) {
  std::string hex;
  for (char c : f.value())
    if (c != ' ' && c != '\t') hex += c;
  if (hex.size() >= 2 && hex[0] == '0' && (hex[1] == 'x' || hex[1] == 'X')) hex.erase(0, 2);
  if (hex.size() % 2 || (!hex.empty() && !is_hex(hex))) f.fail("expected hex bytes, e.g. 0A1B2C");
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i < hex.size(); i += 2)
    out.push_back(std::uint8_t(std::stoul(hex.substr(i, 2), nullptr, 16)));
  return out;
}

// Encodes an integer of type t; hex and octal literals of a signed type may
// give its two's complement bit pattern (0xFFFF for INTEGER16 -1).
void encode_integer(const Field& f, DataType t, std::int64_t v, bool literal_is_bits, std::uint8_t* out) {
  const std::size_t bits = 8 * type_size(t);
  const std::string range = std::string("expected a value in the range of ") + type_name(t);
  if (t == DataType::kBoolean) {
    if (v != 0 && v != 1) f.fail("expected 0 or 1 for BOOLEAN");
  } else if (is_signed(t)) {
    const std::int64_t lo = bits >= 64 ? INT64_MIN : -(std::int64_t(1) << (bits - 1));
    const std::int64_t hi = bits >= 64 ? INT64_MAX : (std::int64_t(1) << (bits - 1)) - 1;
    if (literal_is_bits && bits < 64 && v > hi && !(std::uint64_t(v) >> bits)) v -= std::int64_t(1) << bits;
    if (v < lo || v > hi) f.fail(range);
  } else if (bits < 64 && (v < 0 || std::uint64_t(v) >> bits)) {
    f.fail(range);
  }
  encode_i(t, v, out);
}

// A REAL written as the hex bits of its IEEE 754 form ("0x3E6B851F" = 0.23):
// what some tools write, taken as bits with a warning when they are those of
// a finite number of the type's size.
bool real_bits(const Field& f, DataType t, const std::string& text, std::vector<std::uint8_t>& out) {
  if (normalized(text).rfind("0x", 0) != 0) return false;
  std::int64_t v = 0;
  if (!parse_eds_integer(text, v)) return false;
  const auto bits = std::uint64_t(v);
  double value = 0;
  if (t == DataType::kReal32) {
    if (bits >> 32) return false;
    float x = 0;
    const auto b32 = std::uint32_t(bits);
    std::memcpy(&x, &b32, sizeof x);
    value = x;
  } else {
    std::memcpy(&value, &bits, sizeof value);
  }
  if (!std::isfinite(value)) return false;
  char shown[48];
  std::snprintf(shown, sizeof shown, "%.9g", value);
  f.tolerate(Repair::kRealBits, "expected a decimal floating-point number",
             std::string("read as the IEEE 754 bits of ") + shown);
  encode_f(t, value, out.data());
  return true;
}

// A numeric value of entry `e` into `out` (type_size bytes). `node_id` null:
// no $NODEID term allowed.
void parse_number(const Field& f, DataType t, std::vector<std::uint8_t>& out, bool* node_id) {
  out.assign(type_size(t), 0);
  const std::string text = numeric_text(f.value());
  if (text.empty()) return;  // an empty field is 0 (real files write "DefaultValue=")
  if (is_real(t)) {
    if (real_bits(f, t, text, out)) return;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    const bool hex = text.find_first_of("xX") != std::string::npos;
    // Overflow is infinite; an underflow (ERANGE too) is the subnormal or 0 it gives.
    if (hex || *end || !std::isfinite(v)) f.fail("expected a decimal floating-point number");
    // Halfway above the largest float rounds to infinity (and converting past it is undefined).
    const float top = std::numeric_limits<float>::max();
    const double real32_limit = double(top) + (double(top) - double(std::nextafter(top, 0.0f))) / 2;
    if (t == DataType::kReal32 && std::fabs(v) >= real32_limit) f.fail("expected a number in the range of REAL32");
    encode_f(t, v, out.data());
    return;
  }
  std::int64_t v = 0;
  bool plus = false;
  if (normalized(text) == "true" && t == DataType::kBoolean) v = 1;
  else if (normalized(text) == "false" && t == DataType::kBoolean) v = 0;
  else if (!parse_node_id_sum(text, v, plus) || (plus && !node_id))
    f.fail(node_id ? "expected an integer, optionally plus $NODEID (e.g. $NODEID+0x180)" : "expected an integer");
  if (node_id) *node_id = plus;
  const std::string digits = normalized(text);
  const bool bits = !plus && (digits.rfind("0x", 0) == 0 || (digits.size() > 1 && digits[0] == '0'));
  encode_integer(f, t, v, bits, out.data());
}

// "DefaultValue=0" of a DOMAIN (no bytes in hex): an empty domain.
bool domain_zero(const Field& f, const OdEntry& e) {
  std::int64_t v = -1;
  const std::string text = numeric_text(f.value());
  if (e.type != DataType::kDomain || !parse_eds_integer(text, v) || v != 0) return false;
  std::string digits = normalized(text);
  if (digits.rfind("0x", 0) == 0) digits.erase(0, 2);
  if (digits.size() % 2 == 0) return false;  // "00": one byte 0
  f.tolerate(Repair::kDomainZero, "expected hex bytes, e.g. 0A1B2C", "read as an empty DOMAIN");
  return true;
}

void parse_value(const Field& f, OdEntry& e) {
  if (domain_zero(f, e)) {
    e.default_bytes.clear();
  } else if (e.type == DataType::kOctetString || e.type == DataType::kDomain) {
    e.default_bytes = get_hex_bytes(f);
  } else if (is_variable_size(e.type)) {
    e.default_bytes.assign(f.key->text.begin(), f.key->text.end());
  } else {
    parse_number(f, e.type, e.default_bytes, &e.default_plus_node_id);
  }
}

// ---------------------------------------------------------------- objects

struct SectionName {
  enum Kind { kOther, kObject, kSub, kNames, kValues } kind = kOther;
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
};

SectionName classify(const EdsDocument& doc, const EdsSection& s) {
  const std::string n = normalized(s.name);
  SectionName out;
  if (n.size() < 4 || !is_hex(n.substr(0, 4))) return out;
  out.index = std::uint16_t(std::stoul(n.substr(0, 4), nullptr, 16));
  const std::string rest = n.substr(4);
  if (rest.empty()) out.kind = SectionName::kObject;
  else if (rest == "name") out.kind = SectionName::kNames;
  else if (rest == "value") out.kind = SectionName::kValues;
  else if (rest.rfind("sub", 0) == 0 && rest.size() > 3 && rest.size() <= 5 && is_hex(rest.substr(3))) {
    out.kind = SectionName::kSub;
    out.sub = std::uint8_t(std::stoul(rest.substr(3), nullptr, 16));
  } else {
    reject(doc.file, s.line, "[" + s.name + "]",
           "expected an object section [xxxx], [xxxxsubN], [xxxxName] or [xxxxValue]");
  }
  if (out.index == 0) reject(doc.file, s.line, "[" + s.name + "]", "expected an object index 0x0001..0xFFFF");
  return out;
}

struct ObjectSections {
  const EdsSection* object = nullptr;
  std::map<int, const EdsSection*> subs;
  const EdsSection* names = nullptr;
  const EdsSection* values = nullptr;
};

std::map<std::uint16_t, ObjectSections> group_sections(const EdsDocument& doc) {
  std::map<std::uint16_t, ObjectSections> out;
  for (const EdsSection& s : doc.sections) {
    const SectionName n = classify(doc, s);
    ObjectSections& o = out[n.index];
    switch (n.kind) {
      case SectionName::kOther: break;
      case SectionName::kObject: o.object = &s; break;
      case SectionName::kSub:
        if (o.subs.count(n.sub))
          reject(doc.file, s.line, "[" + s.name + "]",
                 "expected each sub-index once (also [" + o.subs[n.sub]->name + "])");
        o.subs[n.sub] = &s;
        break;
      case SectionName::kNames: o.names = &s; break;
      case SectionName::kValues: o.values = &s; break;
    }
  }
  out.erase(0);
  return out;
}

std::uint8_t persistence_group(const OdEntry& e) {
  // Not stored: read-only and write-only (command) entries, the error history
  // and the store / restore commands themselves.
  const bool value = e.access == Access::kRw || e.access == Access::kRwr || e.access == Access::kRww;
  if (!value || e.index == 0x1003 || e.index == 0x1010 || e.index == 0x1011) return kPersistNone;
  return e.index < 0x2000 ? kPersistCommunication : kPersistApplication;
}

class ObjectReader {
 public:
  ObjectReader(const Source& src, OdLayout& layout, std::optional<std::uint8_t> file_node_id)
      : src_(src), doc_(src.doc), layout_(layout), file_node_id_(file_node_id) {}

  void object(std::uint16_t index, const ObjectSections& o) {
    if (!o.object) {
      const EdsSection* any = o.subs.empty() ? (o.names ? o.names : o.values) : o.subs.begin()->second;
      char buf[64];
      std::snprintf(buf, sizeof buf, "expected an object section [%04X] for this sub-object", index);
      reject(doc_.file, any->line, "[" + any->name + "]", buf);
    }
    const EdsSection& s = *o.object;
    const Field type = field(src_, s, "ObjectType");
    const std::int64_t kind = type.empty() ? 7 : get_integer(type, 0, 255);
    if (kind == 5 || kind == 6 || kind == 0) return;  // DEFTYPE / DEFSTRUCT / NULL: type definitions, no value
    if ((o.names || o.values) && field(src_, s, "CompactSubObj").empty()) {
      const EdsSection* t = o.names ? o.names : o.values;
      reject(doc_.file, t->line, "[" + t->name + "]", "expected CompactSubObj in [" + s.name + "] for this section");
    }
    if (kind == 7 || kind == 2) return variable(index, o);
    if (kind == 8 || kind == 9) return structured(index, ObjectKind(kind), o);
    type.fail("expected ObjectType 0x7 (VAR), 0x8 (ARRAY), 0x9 (RECORD), 0x2 (DOMAIN), 0x5 or 0x6");
  }

 private:
  void variable(std::uint16_t index, const ObjectSections& o) {
    if (!o.subs.empty()) {
      const EdsSection& sub = *o.subs.begin()->second;
      reject(doc_.file, sub.line, "[" + sub.name + "]",
             "expected no sub-object sections for a VAR object (ObjectType 0x8 or 0x9 have them)");
    }
    add(entry(*o.object, index, 0, ObjectKind::kVar));
  }

  void structured(std::uint16_t index, ObjectKind kind, const ObjectSections& o) {
    const EdsSection& s = *o.object;
    const Field compact = field(src_, s, "CompactSubObj");
    const std::int64_t n = compact.empty() ? 0 : get_integer(compact, 0, 254);
    if (n > 0) return compact_subs(index, kind, o, std::uint8_t(n));
    const Field count = field(src_, s, "SubNumber");
    if (!count.empty() && get_integer(count, 0, 255) != std::int64_t(o.subs.size()))
      count.tolerate(Repair::kSubNumber,
                     "expected the number of [" + s.name + "subN] sections (" + std::to_string(o.subs.size()) + ")",
                     "the " + std::to_string(o.subs.size()) + " sections are read");
    if (o.subs.empty()) return no_entries(index, kind, count);
    for (const auto& [sub, section] : o.subs) add(entry(*section, index, std::uint8_t(sub), kind));
  }

  // An ARRAY or RECORD that lists no sub-object (python-canopen's sample
  // does): its sub 0, the highest sub-index, is 0.
  void no_entries(std::uint16_t index, ObjectKind kind, const Field& count) {
    const std::string& name = count.section->name;
    count.tolerate(Repair::kNoSubObjects, "expected [" + name + "subN] sections or CompactSubObj",
                   "read with no entries (sub 0 = 0)");
    add(sub0(index, kind, Access::kConst, "Highest sub-index supported", 0));
  }

  // Sub 0 of an ARRAY or RECORD the file does not write: UNSIGNED8 n.
  static OdEntry sub0(std::uint16_t index, ObjectKind kind, Access access, const char* name, std::uint8_t n) {
    OdEntry e;
    e.index = index;
    e.kind = kind;
    e.type = DataType::kUnsigned8;
    e.access = access;
    e.name = name;
    e.default_bytes = {n};
    return e;
  }

  // CiA 306 §4.5.2.4 (compact storage): sub 0 holds the number of entries,
  // subs 1..n share the object's type, access, limits and default; names
  // and values of single subs may come from [xxxxName] / [xxxxValue].
  void compact_subs(std::uint16_t index, ObjectKind kind, const ObjectSections& o, std::uint8_t n) {
    const EdsSection& s = *o.object;
    if (!o.subs.empty()) {
      const EdsSection& sub = *o.subs.begin()->second;
      reject(doc_.file, sub.line, "[" + sub.name + "]",
             "expected no sub-object sections with CompactSubObj in [" + s.name + "]");
    }
    OdEntry count = sub0(index, kind, Access::kRo, "Number of entries", n);
    if (index == 0x1003) {  // CiA 301 §7.5.2.5: the number of errors recorded, 0 at boot, 0 written clears
      count.access = Access::kRw;
      count.default_bytes = {0};
    }
    add(count);
    const OdEntry shared = entry(s, index, 1, kind);
    for (int sub = 1; sub <= n; ++sub) {
      OdEntry e = shared;
      e.sub = std::uint8_t(sub);
      e.name = shared.name + " " + std::to_string(sub);
      if (o.names) named_sub(*o.names, e, [&](const Field& f) { e.name = f.value(); });
      if (o.values) named_sub(*o.values, e, [&](const Field& f) { set_value(f, e); });
      add(std::move(e));
    }
    for (const EdsSection* table : {o.names, o.values})
      if (table) check_table(*table, n);
  }

  template <typename Apply>
  // The key of sub `e.sub` in any number form ("2", "0x2", "02").
  void named_sub(const EdsSection& table, const OdEntry& e, Apply&& apply) {
    for (const EdsKey& k : table.keys) {
      std::int64_t sub = 0;
      if (k.key == "nrofentries" || !parse_eds_integer(k.name, sub) || sub != e.sub) continue;
      const Field f{&src_, &table, &k, k.name};
      if (!f.empty()) apply(f);
      return;
    }
  }

  void check_table(const EdsSection& table, std::uint8_t n) {
    for (const EdsKey& k : table.keys) {
      if (k.key == "nrofentries") continue;
      std::int64_t sub = 0;
      if (!parse_eds_integer(k.name, sub) || sub < 1 || sub > n)
        reject(doc_.file, k.line, "[" + table.name + "] " + k.name,
               "expected NrOfEntries or a sub-index 1.." + std::to_string(n) + " (CompactSubObj)");
    }
  }

  OdEntry entry(const EdsSection& s, std::uint16_t index, std::uint8_t sub, ObjectKind kind) {
    OdEntry e;
    e.index = index;
    e.sub = sub;
    e.kind = kind;
    const Field name = field(src_, s, "ParameterName");
    if (name) e.name = name.value();
    const Field type = field(src_, s, "DataType");
    if (type.empty()) type.fail("missing required key");
    const bool basic = read_data_type(type, e.type);
    const Field access = field(src_, s, "AccessType");
    if (access.empty()) access.fail("missing required key");
    if (!parse_access(normalized(access.value()), e.access)) access.fail("expected one of ro, wo, rw, rwr, rww, const");
    const Field pdo = field(src_, s, "PDOMapping");
    e.pdo_mappable = !pdo.empty() && get_flag(pdo);
    const Field flags = field(src_, s, "ObjFlags");
    if (!flags.empty()) get_integer(flags, 0, 0xFFFFFFFF);  // CiA 306 §4.5.2.1: tool hints, no node behaviour
    if (basic) {
      value(s, e);
      limits(s, e);
    }
    if (is_variable_size(e.type))
      e.capacity =
          std::uint32_t(std::max<std::size_t>(e.default_bytes.size(), e.type == DataType::kDomain ? 4096 : 255));
    e.persist = persistence_group(e);
    return e;
  }

  // A CiA 301 basic data type: true. A complex, manufacturer or device
  // profile type (0x0020-0x025F, CiA 306 §4.6.3), which this reader does not
  // know (python-canopen's sample has 0x40), is a repair:
  // an empty DOMAIN, its bytes as a master writes them, its value and limits
  // (that type's) not read: false.
  bool read_data_type(const Field& type, DataType& out) {
    const std::int64_t t = get_integer(type, 0, 0xFFFF);
    if (t >= 1 && t <= 0x1F && std::string_view(type_name(DataType(t))) != "?") {
      out = DataType(t);
      return true;
    }
    const char* expected =
        "expected a CiA 301 basic data type 0x0001..0x001B (BOOLEAN, INTEGERn, UNSIGNEDn, REAL32/64, strings, DOMAIN)";
    if (t < 0x20 || t > 0x25F) type.fail(expected);
    type.tolerate(Repair::kUnknownDataType, expected, "read as an empty DOMAIN, its value and limits not read");
    out = DataType::kDomain;
    return false;
  }

  // A DCF's ParameterValue (the configured value) wins over DefaultValue
  // when it has a value: CANopenEditor writes "ParameterValue=" for "not set".
  void value(const EdsSection& s, OdEntry& e) {
    const Field configured = field(src_, s, "ParameterValue");
    const Field preset = field(src_, s, "DefaultValue");
    // Blanks are a string's value ("DefaultValue=    "), a number's absence.
    const bool text = is_variable_size(e.type) && e.type != DataType::kOctetString && e.type != DataType::kDomain;
    auto given = [&](const Field& f) { return f && !(text ? f.key->text : f.value()).empty(); };
    const Field& chosen = given(configured) ? configured : preset;
    if (given(chosen)) set_value(chosen, e);
    else if (!is_variable_size(e.type)) e.default_bytes.assign(type_size(e.type), 0);
  }

  void set_value(const Field& f, OdEntry& e) {
    parse_value(f, e);
    if (const std::uint32_t base = default_sdo_base(e)) check_default_sdo_cob_id(f, e, base);
  }

  // CiA 301 §7.2.4.3.2 (predefined connection set): the default SDO server
  // (0x1200) answers at 600h / 580h + node-ID, whatever the file says.
  static std::uint32_t default_sdo_base(const OdEntry& e) {
    if (e.index != 0x1200 || (e.sub != 1 && e.sub != 2) || type_size(e.type) != 4) return 0;
    return e.sub == 1 ? cob::kSdoRxBase : cob::kSdoTxBase;
  }

  // A value for the file's own node (0x605 in a DCF of node 5) is that; any
  // other (another node's, an invalid 0x80000000) is repaired with a warning.
  void check_default_sdo_cob_id(const Field& f, const OdEntry& e, std::uint32_t base) const {
    const auto v = std::uint32_t(decode_u(e.type, e.default_bytes.data()));
    if (v == base && e.default_plus_node_id) return;
    if (!e.default_plus_node_id && file_node_id_ && v == base + *file_node_id_) return;
    char expected[96];
    std::snprintf(expected, sizeof expected, "expected $NODEID+0x%X (the default SDO server's COB-ID)", base);
    char done[64];
    std::snprintf(done, sizeof done, "the node uses 0x%X + its node-ID", base);
    f.tolerate(Repair::kSdoServerCobId, expected, done);
  }

  void limits(const EdsSection& s, OdEntry& e) {
    for (const char* key : {"LowLimit", "HighLimit"}) {
      const Field f = field(src_, s, key);
      if (f.empty()) continue;
      if (is_variable_size(e.type)) f.fail(std::string("expected no limit for ") + type_name(e.type));
      std::vector<std::uint8_t> bytes;
      bool plus_node_id = false;
      parse_number(f, e.type, bytes, &plus_node_id);
      if (plus_node_id) {  // CiA 306 allows it; the node's limits are fixed
        f.tolerate(Repair::kNodeIdLimit, "expected an integer", "the limit is not applied");
        continue;
      }
      const bool low = key[0] == 'L';
      std::copy(bytes.begin(), bytes.end(), low ? e.low : e.high);
      (low ? e.has_low : e.has_high) = true;
    }
  }

  // Slots are 16-bit and OdLayout::add checks duplicates linearly: a bound
  // far above real devices keeps hostile files cheap.
  static constexpr std::size_t kMaxEntries = 8192;

  void add(OdEntry e) {
    if (const std::uint32_t base = default_sdo_base(e)) {
      encode_i(e.type, base, e.default_bytes.data());
      e.default_plus_node_id = true;
    }
    if (layout_.entries().size() >= kMaxEntries)
      throw ConfigError(doc_.file + ":1: (top level): expected at most " + std::to_string(kMaxEntries) +
                        " sub-objects in all");
    layout_.add(std::move(e));
  }

  const Source& src_;
  const EdsDocument& doc_;
  OdLayout& layout_;
  std::optional<std::uint8_t> file_node_id_;  // [DeviceComissioning] NodeID, when the file states it
};

// [MandatoryObjects] / [OptionalObjects] / [ManufacturerObjects]: tool
// hints (the node has every [xxxx] section); a count other than the keys or
// a listed object without its section is repaired with a warning.
void check_object_lists(const Source& src, const std::map<std::uint16_t, ObjectSections>& objects) {
  for (const char* list : {"MandatoryObjects", "OptionalObjects", "ManufacturerObjects"}) {
    const EdsSection* s = src.doc.find(list);
    if (!s) continue;
    const Field count = field(src, *s, "SupportedObjects");
    const std::int64_t n = count.empty() ? 0 : get_integer(count, 0, 0xFFFF);
    std::int64_t given = 0;
    for (const EdsKey& k : s->keys) {
      std::int64_t i = 0;
      if (k.key == "supportedobjects" || !parse_eds_integer(k.name, i)) continue;
      const Field f{&src, s, &k, k.name};
      if (f.empty()) continue;
      ++given;
      const auto index = std::uint16_t(get_integer(f, 1, 0xFFFF));
      auto it = objects.find(index);
      if (it == objects.end() || !it->second.object) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "expected a section [%04X] for this listed object", index);
        f.tolerate(Repair::kListedMissing, buf, "the entry is ignored");
      }
    }
    if (given != n)
      count.tolerate(Repair::kObjectCount, "expected the number of object keys (" + std::to_string(given) + ")",
                     "the " + std::to_string(given) + " keys are read");
  }
}

// ---------------------------------------------------------------- device info

constexpr struct {
  const char* key;
  std::uint32_t kbit;
} kBaudKeys[] = {{"BaudRate_10", 10},   {"BaudRate_20", 20},   {"BaudRate_50", 50},   {"BaudRate_125", 125},
                 {"BaudRate_250", 250}, {"BaudRate_500", 500}, {"BaudRate_800", 800}, {"BaudRate_1000", 1000}};

// LSS support, bit rates and dummy mapping, where the file states them.
void device_options(const Source& src, Profile& p) {
  const EdsDocument& doc = src.doc;
  NodeOptions& o = *p.options;
  if (const EdsSection* info = doc.find("DeviceInfo")) {
    if (const Field lss = field(src, *info, "LSS_Supported"); !lss.empty()) o.lss_supported = get_flag(lss);
    std::string rates;
    std::vector<std::uint32_t> supported;
    for (const auto& b : kBaudKeys) {
      const Field f = field(src, *info, b.key);
      if (f.empty() || !get_flag(f)) continue;
      rates += (rates.empty() ? "" : ",") + std::to_string(bit_rate_index(b.kbit));
      supported.push_back(b.kbit);
    }
    if (!rates.empty()) ByteSet::parse(rates, o.lss_bit_rates);
    if (!supported.empty() && std::find(supported.begin(), supported.end(), 250u) == supported.end())
      p.bit_rate_kbit = supported.front();
  }
  if (const EdsSection* dummies = doc.find("DummyUsage")) {
    bool any = false, stated = false;
    for (const EdsKey& k : dummies->keys) {
      const Field f{&src, dummies, &k, k.name};
      if (f.empty()) continue;
      stated = true;
      any |= get_flag(f);
    }
    if (stated) o.rpdo_dummy_mapping = any;
  }
}

// [DeviceComissioning] (CiA 306 spelling; "Commissioning" accepted too).
// Returns the node-ID the file states. 0 is CANopenEditor's "not set".
std::optional<std::uint8_t> commissioning(const Source& src, Profile& p) {
  const EdsSection* s = src.doc.find("DeviceComissioning");
  if (!s) s = src.doc.find("DeviceCommissioning");
  if (!s) return std::nullopt;
  std::optional<std::uint8_t> stated;
  if (const Field id = field(src, *s, "NodeID"); !id.empty()) {
    const std::int64_t v = get_integer(id, 0, 255);
    if (v > 127 && v != 255) id.fail("expected a node-ID 1..127 or 255 (LSS-unconfigured)");
    if (v == 0)
      id.tolerate(Repair::kUnsetCommissioning, "expected a node-ID 1..127 or 255 (LSS-unconfigured)",
                  "taken as not set (node-ID " + std::to_string(p.node_id) + ")");
    else stated = p.node_id = std::uint8_t(v);
  }
  if (const Field rate = field(src, *s, "Baudrate"); !rate.empty()) {
    const char* expected = "expected a CiA bit rate in kbit/s: 1000, 800, 500, 250, 125, 50, 20 or 10";
    const std::int64_t v = get_integer(rate, 0, 1000);
    if (v != 0 && bit_rate_index(std::uint32_t(v)) < 0) rate.fail(expected);
    if (v == 0)
      rate.tolerate(Repair::kUnsetCommissioning, expected,
                    "taken as not set (" + std::to_string(p.bit_rate_kbit) + " kbit/s)");
    else p.bit_rate_kbit = std::uint32_t(v);
  }
  return stated;
}

std::string profile_name(const std::string& file) {
  std::string stem = std::filesystem::path(file).stem().string();
  for (char& c : stem)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.')) c = '-';
  return stem.empty() ? "eds" : stem;
}

std::string text_of(const EdsDocument& doc, const char* section, const char* key) {
  const EdsSection* s = doc.find(section);
  const EdsKey* k = s ? s->find(key) : nullptr;
  return k ? k->value : std::string();
}

}  // namespace

const EdsKey* EdsSection::find(std::string_view key) const {
  const std::string want = normalized(key);
  for (const EdsKey& k : keys)
    if (k.key == want) return &k;
  return nullptr;
}

const EdsSection* EdsDocument::find(std::string_view section) const {
  const std::string want = normalized(section);
  for (const EdsSection& s : sections)
    if (s.key == want) return &s;
  return nullptr;
}

bool parse_eds_integer(std::string_view raw, std::int64_t& out) {
  std::string_view text = trimmed(raw);
  bool negative = false;
  if (!text.empty() && (text.front() == '-' || text.front() == '+')) {
    negative = text.front() == '-';
    text.remove_prefix(1);
  }
  if (text.empty()) return false;
  int base = 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    base = 16;
    text.remove_prefix(2);
  } else if (text.size() > 1 && text[0] == '0') {
    base = 8;
  }
  const std::string digits(text);
  const char* valid = base == 16 ? "0123456789abcdefABCDEF" : base == 8 ? "01234567" : "0123456789";
  if (digits.find_first_not_of(valid) != std::string::npos) return false;
  errno = 0;
  const unsigned long long v = std::strtoull(digits.c_str(), nullptr, base);
  if (errno) return false;
  if (negative) {
    if (v > 0x8000000000000000ULL) return false;
    out = v ? -std::int64_t(v - 1) - 1 : 0;
  } else {
    out = std::int64_t(v);  // above INT64_MAX wraps: UNSIGNED64 callers take the bits
  }
  return true;
}

EdsDocument parse_eds(const std::string& text, const std::string& file) { return LineParser(text, file).run(); }

EdsDocument load_eds_file(const std::string& path) {
  return parse_eds(read_regular_file(path, limits::kProfileFileBytes), path);
}

Profile profile_from_eds(const EdsDocument& doc, bool strict, bool strict_eds) {
  Profile p;
  p.file = doc.file;
  p.name = profile_name(doc.file);
  p.description = text_of(doc, "FileInfo", "Description");
  if (p.description.empty()) p.description = text_of(doc, "DeviceInfo", "ProductName");
  p.personality = "generic";
  p.node_id = 1;
  p.bit_rate_kbit = 250;
  p.options = std::make_shared<NodeOptions>();
  Repairs repairs(strict_eds);
  const Source src{doc, repairs};
  device_options(src, p);
  const std::optional<std::uint8_t> file_node_id = commissioning(src, p);
  p.layout = std::make_shared<OdLayout>();
  const auto objects = group_sections(doc);
  check_object_lists(src, objects);
  ObjectReader reader(src, *p.layout, file_node_id);
  for (const auto& [index, sections] : objects) reader.object(index, sections);
  if (p.layout->entries().empty())
    throw ConfigError(doc.file + ":1: (top level): expected at least one object section [xxxx]");
  p.layout->finalize();
  // The generic personality with the CiA 404 chain on the file's channels
  // and the default physics: what a YAML profile without `vendor:`,
  // `physics:`, `sensor:` or `faults:` gets.
  const YAML::Node none(YAML::NodeType::Map);
  parse_strict_sections(Where{doc.file, ""}, none, p, strict);
  parse_personality(p, none, YAML::Node());
  p.warnings = repairs.warnings();
  return p;
}

Profile load_eds_profile(const std::string& path, bool strict, bool strict_eds) {
  return profile_from_eds(load_eds_file(path), strict, strict_eds);
}

bool is_device_description(const std::string& path) {
  const std::string ext = normalized(std::filesystem::path(path).extension().string());
  return ext == ".eds" || ext == ".dcf";
}

}  // namespace cansim::config
