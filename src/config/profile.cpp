#include "config/profile.hpp"

#include <cmath>
#include <cstdio>

#include "config/cia404_yaml.hpp"
#include "config/physics_config.hpp"
#include "config/vendor_settings.hpp"
#include "personalities/catalog.hpp"

#include "config/strict_mode.hpp"

namespace cansim::config {

namespace {

constexpr std::uint32_t kBitRates[] = {1000, 800, 500, 250, 125, 0, 50, 20, 10};

// Integer default as a sum of literals with an optional node-ID term:
// "0x180+$NODEID", "$NODEID + 0x200", "0x80000000+0x280+$NODEID".
bool parse_node_id_expr(const std::string& text, std::int64_t& value, bool& plus_node_id) {
  std::string s;
  for (char c : text)
    if (c != ' ') s += c;
  plus_node_id = false;
  value = 0;
  if (s.empty()) return false;
  std::size_t start = 0;
  while (start <= s.size()) {
    std::size_t end = s.find('+', start == 0 && (s[0] == '+') ? 1 : start);
    if (end == std::string::npos) end = s.size();
    std::string term = s.substr(start, end - start);
    std::string upper = term;
    for (char& c : upper) c = char(std::toupper(static_cast<unsigned char>(c)));
    if (upper == "$NODEID" || upper == "NODEID") {
      if (plus_node_id) return false;
      plus_node_id = true;
    } else {
      std::int64_t v = 0;
      if (!parse_int_literal(term, v)) return false;
      value += v;
    }
    if (end == s.size()) break;
    start = end + 1;
  }
  return true;
}

void parse_value(const Where& w, const YAML::Node& n, OdEntry& e, std::vector<std::uint8_t>& out, bool* plus_node_id) {
  if (is_variable_size(e.type)) {
    std::string s = n.IsScalar() ? n.Scalar() : "";
    if (e.type == DataType::kOctetString || e.type == DataType::kDomain) {
      // Octet strings and domains take hex bytes: "01 02 ff" or "0102ff".
      std::string hex;
      for (char c : s)
        if (!std::isspace(static_cast<unsigned char>(c))) hex += c;
      if (hex.size() % 2) fail(w, n, "expected hex bytes");
      out.clear();
      for (std::size_t i = 0; i < hex.size(); i += 2) {
        std::int64_t b = 0;
        if (!parse_int_literal("0x" + hex.substr(i, 2), b)) fail(w, n, "expected hex bytes");
        out.push_back(std::uint8_t(b));
      }
    } else {
      out.assign(s.begin(), s.end());
    }
    return;
  }
  out.assign(type_size(e.type), 0);
  std::string text = get_string(w, n);
  if (is_real(e.type)) {
    encode_f(e.type, get_double(w, n), out.data());
    return;
  }
  std::int64_t v = 0;
  bool plus = false;
  if (!parse_node_id_expr(text, v, plus) || (plus && !plus_node_id))
    fail(w, n, std::string("expected an integer") + (plus_node_id ? " (optionally with +$NODEID)" : ""));
  if (plus_node_id) *plus_node_id = plus;
  std::size_t bits = 8 * type_size(e.type);
  if (e.type == DataType::kBoolean) {
    if (v != 0 && v != 1) fail(w, n, "expected 0 or 1 for BOOLEAN");
  } else if (is_signed(e.type)) {
    std::int64_t lo = bits >= 64 ? INT64_MIN : -(std::int64_t(1) << (bits - 1));
    std::int64_t hi = bits >= 64 ? INT64_MAX : (std::int64_t(1) << (bits - 1)) - 1;
    if (v < lo || v > hi) fail(w, n, std::string("value out of range for ") + type_name(e.type));
  } else if (bits < 64 && (v < 0 || std::uint64_t(v) >> bits)) {
    fail(w, n, std::string("value out of range for ") + type_name(e.type));
  }
  encode_i(e.type, v, out.data());
}

std::uint8_t parse_persist(const Where& w, const YAML::Node& n, std::uint16_t index) {
  std::string s = get_string(w, n);
  if (s == "no" || s == "false" || s == "none" || s == "unknown") return kPersistNone;
  if (s == "yes" || s == "true") return index >= 0x1000 && index < 0x2000 ? kPersistCommunication : kPersistApplication;
  if (s == "communication") return kPersistCommunication;
  if (s == "application") return kPersistApplication;
  std::int64_t v = 0;
  if (parse_int_literal(s, v) && v >= 2 && v <= 127) return std::uint8_t(v);
  fail(w, n, "expected yes, no, communication, application or a 0x1010 sub-index 2..127");
}

// Names are unique within an object (EDS ParameterName): a range numbers its
// sub-indices, before a closing remark ("AI input PV 1", "AI input PV 1 (INTEGER16)").
std::string numbered_name(const std::string& name, int sub) {
  if (name.empty()) return name;
  const std::size_t remark = name.back() == ')' ? name.rfind(" (") : std::string::npos;
  if (remark == std::string::npos || remark == 0) return name + " " + std::to_string(sub);
  return name.substr(0, remark) + " " + std::to_string(sub) + name.substr(remark);
}

// "0x02..0x08" or a single number.
void parse_sub_range(const Where& w, const YAML::Node& n, int& first, int& last) {
  std::string s = get_string(w, n);
  auto dots = s.find("..");
  std::int64_t a = 0, b = 0;
  if (dots == std::string::npos) {
    if (!parse_int_literal(s, a) || a < 0 || a > 255) fail(w, n, "expected a sub-index 0..255 or a range 'a..b'");
    first = last = int(a);
    return;
  }
  if (!parse_int_literal(s.substr(0, dots), a) || !parse_int_literal(s.substr(dots + 2), b) || a < 0 || b > 255 ||
      a > b)
    fail(w, n, "expected a sub-index 0..255 or a range 'a..b'");
  first = int(a);
  last = int(b);
}

}  // namespace

int bit_rate_index(std::uint32_t kbit) {
  for (int i = 0; i < 9; ++i)
    if (kBitRates[i] == kbit && kbit) return i;
  return -1;
}
std::uint32_t bit_rate_kbit(int index) { return index >= 0 && index < 9 ? kBitRates[index] : 0; }
std::uint8_t bit_rate_selector(std::uint32_t kbit) {
  const int i = bit_rate_index(kbit);
  return i < 0 ? 0xFF : std::uint8_t(i);
}

NodeSetup node_setup(const Profile& profile, std::optional<std::uint8_t> node_id, std::uint32_t index) {
  NodeSetup setup;
  if (profile.identity.serial_per_node) setup.serial_number = profile.identity.serial_base + index;
  setup.layout = profile.layout;
  setup.options = profile.options;
  setup.node_id = node_id.value_or(profile.node_id);
  setup.bit_rate_index = bit_rate_selector(profile.bit_rate_kbit);
  return setup;
}

void parse_objects(const Where& w, const YAML::Node& list, OdLayout& out) {
  if (!list.IsSequence()) fail(w, list, "expected a list of object dictionary entries");
  for (std::size_t i = 0; i < list.size(); ++i) {
    Where wi = w.item(i);
    const YAML::Node& row = list[i];
    check_keys(wi, row,
               {"index", "sub", "name", "kind", "type", "access", "default", "pdo_mappable", "persistent", "low",
                "high", "max_length", "hook", "notes"});
    auto need = [&](const char* key) {
      if (!row[key]) fail(wi.child(key), row, std::string("missing required key '") + key + "'");
      return row[key];
    };
    OdEntry e;
    e.index = std::uint16_t(get_int(wi.child("index"), need("index"), 1, 0xFFFF));
    int first = 0, last = 0;
    if (row["sub"]) parse_sub_range(wi.child("sub"), row["sub"], first, last);
    e.name = row["name"] ? get_string(wi.child("name"), row["name"]) : "";
    std::string type = get_string(wi.child("type"), need("type"));
    if (!parse_type(type, e.type))
      fail(wi.child("type"), row["type"],
           "expected a CiA 301 type name (UNSIGNED8, INTEGER32, REAL32, VISIBLE_STRING, DOMAIN, ...)");
    std::string access = get_string(wi.child("access"), need("access"));
    if (!parse_access(access, e.access))
      fail(wi.child("access"), row["access"], "expected one of ro, wo, rw, rwr, rww, const");
    if (row["kind"]) {
      std::string k = get_string(wi.child("kind"), row["kind"]);
      if (k == "var") e.kind = ObjectKind::kVar;
      else if (k == "array") e.kind = ObjectKind::kArray;
      else if (k == "record") e.kind = ObjectKind::kRecord;
      else fail(wi.child("kind"), row["kind"], "expected var, array or record");
    } else {
      e.kind = (first == 0 && last == 0) ? ObjectKind::kVar : ObjectKind::kRecord;
    }
    if (row["pdo_mappable"]) e.pdo_mappable = get_bool(wi.child("pdo_mappable"), row["pdo_mappable"]);
    if (row["persistent"]) e.persist = parse_persist(wi.child("persistent"), row["persistent"], e.index);
    if (row["hook"]) {
      std::string h = get_string(wi.child("hook"), row["hook"]);
      if (h == "read") e.hooks = kHookRead;
      else if (h == "write") e.hooks = kHookWrite;
      else if (h == "read-write" || h == "both") e.hooks = kHookRead | kHookWrite;
      else fail(wi.child("hook"), row["hook"], "expected read, write or both");
    }
    if (is_variable_size(e.type)) {
      std::int64_t max = row["max_length"] ? get_int(wi.child("max_length"), row["max_length"], 0, 65536) : -1;
      e.capacity = std::uint32_t(max < 0 ? 0 : max);
    } else if (row["max_length"]) {
      fail(wi.child("max_length"), row["max_length"], "max_length applies only to strings and DOMAIN");
    }
    if (row["default"]) {
      const YAML::Node& d = row["default"];
      if (!d.IsScalar()) fail(wi.child("default"), d, "expected a scalar default value");
      parse_value(wi.child("default"), d, e, e.default_bytes, &e.default_plus_node_id);
    } else if (!is_variable_size(e.type)) {
      e.default_bytes.assign(type_size(e.type), 0);
    }
    if (is_variable_size(e.type) && e.capacity < e.default_bytes.size())
      e.capacity = std::uint32_t(std::max<std::size_t>(e.default_bytes.size(), row["max_length"] ? 0 : 32));
    if (is_variable_size(e.type) && !row["max_length"] && e.capacity < 32) e.capacity = 32;
    for (const char* key : {"low", "high"}) {
      if (!row[key]) continue;
      if (is_variable_size(e.type)) fail(wi.child(key), row[key], "limits apply only to numeric types");
      std::vector<std::uint8_t> bytes;
      bool dummy = false;
      parse_value(wi.child(key), row[key], e, bytes, &dummy);
      std::uint8_t* dst = key[0] == 'l' ? e.low : e.high;
      std::copy(bytes.begin(), bytes.end(), dst);
      (key[0] == 'l' ? e.has_low : e.has_high) = true;
    }
    for (int sub = first; sub <= last; ++sub) {
      OdEntry copy = e;
      copy.sub = std::uint8_t(sub);
      if (first < last) copy.name = numbered_name(e.name, sub);
      if (!out.add(std::move(copy))) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "duplicate entry 0x%04X:%02X", e.index, sub);
        fail(wi, row, buf);
      }
    }
  }
}

namespace {

// One option's value as its kind declares it (node_options.hpp): a value the
// kind refuses fails with what it expected.
template <class Kind>
void parse_option(const Where& w, const YAML::Node& n, const Kind& kind, typename Kind::Value& out) {
  if constexpr (std::is_same_v<Kind, option_kind::Bool>) {
    out = get_bool(w, n);
  } else if constexpr (std::is_same_v<Kind, option_kind::Int>) {
    std::int64_t v = 0;
    if (!n.IsScalar() || !parse_int_literal(n.Scalar(), v) || v < kind.lo || v > kind.hi) fail(w, n, kind.expected());
    out = v;
  } else {
    if (!n.IsScalar() || !kind.parse(n.Scalar(), out)) fail(w, n, kind.expected());
  }
}

}  // namespace

void parse_options(const Where& w, const YAML::Node& map, NodeOptions& out) {
  if (!map) return;
  if (!map.IsMap()) fail(w, map, "expected a mapping of option names to values");
  for (const auto& kv : map) {
    std::string key = kv.first.Scalar();
    Where wk = w.child(key);
    bool known = false;
#define CANSIM_PARSE_OPTION(kind, name, def, strict, help)            \
  if (key == #name) {                                                 \
    parse_option(wk, kv.second, CANSIM_OPTION_KIND_##kind, out.name); \
    known = true;                                                     \
  }
    CANSIM_NODE_OPTIONS(CANSIM_PARSE_OPTION)
#undef CANSIM_PARSE_OPTION
    if (!known) fail(wk, kv.first, "unknown option (see docs/profiles.md, 'Profile options')");
  }
}

// `emcy: {0x3201: "Over flow / under flow (Table 24)", ...}`.
void parse_emcy_codes(const Where& w, const YAML::Node& map, std::map<std::uint16_t, std::string>& out) {
  if (!map) return;
  if (!map.IsMap()) fail(w, map, "expected a mapping of EMCY error codes to their meaning");
  for (const auto& kv : map) {
    std::int64_t code = 0;
    const std::string key = kv.first.as<std::string>();
    if (!parse_int_literal(key, code) || code < 0 || code > 0xFFFF)
      fail(w, kv.first, "expected an EMCY error code 0x0000..0xFFFF, got '" + key + "'");
    out[std::uint16_t(code)] = get_string(w.child(key), kv.second);
  }
}

Profile parse_profile(const YAML::Node& root, const std::string& file, bool strict) {
  Where w{file, ""};
  if (!root.IsMap()) fail(w, root, "expected a profile mapping");
  check_keys(w, root,
             {"name", "description", "personality", "node_id", "bit_rate", "options", "objects", "vendor", "physics",
              "sensor", "faults", "strict", "quirks", "strict_objects", "emcy"});
  Profile p;
  p.file = file;
  if (root["name"]) p.name = get_string(w.child("name"), root["name"]);
  if (root["description"]) p.description = get_string(w.child("description"), root["description"]);
  if (root["personality"]) p.personality = get_string(w.child("personality"), root["personality"]);
  if (root["node_id"]) {
    std::int64_t id = get_int(w.child("node_id"), root["node_id"], 1, 255);
    if (id > 127 && id != 255)
      fail(w.child("node_id"), root["node_id"], "expected a node-ID 1..127 or 255 (LSS-unconfigured)");
    p.node_id = std::uint8_t(id);
  }
  if (root["bit_rate"]) {
    p.bit_rate_kbit = std::uint32_t(get_int(w.child("bit_rate"), root["bit_rate"], 1, 1000));
    if (bit_rate_index(p.bit_rate_kbit) < 0)
      fail(w.child("bit_rate"), root["bit_rate"],
           "expected a CiA bit rate in kbit/s: 1000, 800, 500, 250, 125, 50, 20 or 10");
  }
  p.options = std::make_shared<NodeOptions>();
  parse_options(w.child("options"), root["options"], *p.options);
  p.layout = std::make_shared<OdLayout>();
  if (!root["objects"]) fail(w.child("objects"), root, "missing the object dictionary ('objects:' list)");
  parse_objects(w.child("objects"), root["objects"], *p.layout);
  p.layout->finalize();
  parse_emcy_codes(w.child("emcy"), root["emcy"], p.emcy_codes);
  parse_strict_sections(w, root, p, strict);
  parse_personality(p, root, root["vendor"]);
  return p;
}

namespace {

// A missing-object error points at the `objects:` list.
[[noreturn]] void fail_objects(const Profile& p, const YAML::Node& root, const std::string& expected) {
  fail(Where{p.file, "objects"}, root["objects"] ? root["objects"] : root, expected);
}

void check_requirements(const Profile& p, const YAML::Node& root, const personalities::Requirements& needs) {
  for (const personalities::RequiredObject& o : needs.objects)
    for (unsigned sub = o.first_sub; sub <= o.last_sub; ++sub) {
      const OdEntry* e = p.layout->find(o.index, std::uint8_t(sub));
      if (e && !is_variable_size(e->type) && (e->hooks & o.hooks) != o.hooks) {
        char id[16];
        std::snprintf(id, sizeof id, "0x%04X:%02X", o.index, sub);
        const bool both = (o.hooks & kHookRead) && (o.hooks & kHookWrite);
        fail_objects(p, root,
                     std::string("object ") + id + " with hook: " +
                         (both                  ? "both"
                          : o.hooks & kHookRead ? "read"
                                                : "write") +
                         " (personality " + p.personality + " needs it for " + o.purpose + ")");
      }
      if (e && !is_variable_size(e->type)) continue;
      char id[16];
      std::snprintf(id, sizeof id, "0x%04X:%02X", o.index, sub);
      fail_objects(p, root,
                   std::string("a numeric object ") + id + " (personality " + p.personality + " needs it for " +
                       o.purpose + ")" + (e ? ", not a string or domain" : ""));
    }
  if (p.cia404->channels.size() < needs.channels)
    fail_objects(p, root,
                 "at least " + std::to_string(needs.channels) +
                     " CiA 404 channel(s) (0x6130:01.. with their vendor.cia404 channels; personality " +
                     p.personality + " needs them for " + needs.channels_purpose + ")");
}

}  // namespace

void parse_personality(Profile& p, const YAML::Node& root, const YAML::Node& vendor, const VendorLayer* over) {
  const personalities::PersonalityInfo* info = personalities::find_personality(p.personality);
  if (!info)
    fail(Where{p.file, "personality"}, root["personality"],
         "unknown personality '" + p.personality + "' (expected: " + personalities::personality_names() + ")");
  const VendorParams v(p.file, vendor, over);
  const std::shared_ptr<model::Cia404Profile> chain = parse_cia404(v.where("cia404"), v.node("cia404"), *p.layout);
  p.cia404 = chain;
  p.identity = parse_identity(v);
  p.physics = parse_physics_config(p.file, root);
  check_requirements(p, root, info->requirements());
  p.device = info->default_settings();
  parse_device_settings(v, p);
  apply_setting_strictness(p, chain->settings, root);
}

Profile parse_profile(const std::string& text, const std::string& file, bool strict) {
  return parse_profile(load_yaml_text(text, file), file, strict);
}

Profile load_profile(const std::string& path, bool strict) { return parse_profile(load_yaml_file(path), path, strict); }

}  // namespace cansim::config
