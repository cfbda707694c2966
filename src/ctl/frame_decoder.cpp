#include "ctl/frame_decoder.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>

#include "core/protocol.hpp"
#include "ctl/canopen_text.hpp"
#include "ctl/json.hpp"

namespace cansim::ctl {

namespace {

std::uint64_t little_endian(const std::uint8_t* p, std::size_t n) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < n; ++i) v |= std::uint64_t(p[i]) << (8 * i);
  return v;
}

// Bits [first, first + count) of the frame's data, little-endian (CiA 301 §7.4.8.2).
std::uint64_t bit_field(const std::uint8_t* data, unsigned first, unsigned count) {
  std::uint64_t v = 0;
  for (unsigned i = 0; i < count; ++i) {
    unsigned bit = first + i;
    if (data[bit / 8] >> (bit % 8) & 1) v |= std::uint64_t(1) << i;
  }
  return v;
}

std::int64_t sign_extend(std::uint64_t v, unsigned bits) {
  if (bits == 0 || bits >= 64) return std::int64_t(v);
  const std::uint64_t sign = std::uint64_t(1) << (bits - 1);
  return std::int64_t((v ^ sign) - sign);
}

struct TypeShape {
  std::string_view name;
  char kind;  // b bool, i signed, u unsigned, f real, s string, a bytes
  unsigned bytes;
};
constexpr TypeShape kTypes[] = {
    {"BOOLEAN", 'b', 1},        {"INTEGER8", 'i', 1},     {"INTEGER16", 'i', 2},  {"INTEGER24", 'i', 3},
    {"INTEGER32", 'i', 4},      {"INTEGER40", 'i', 5},    {"INTEGER48", 'i', 6},  {"INTEGER56", 'i', 7},
    {"INTEGER64", 'i', 8},      {"UNSIGNED8", 'u', 1},    {"UNSIGNED16", 'u', 2}, {"UNSIGNED24", 'u', 3},
    {"UNSIGNED32", 'u', 4},     {"UNSIGNED40", 'u', 5},   {"UNSIGNED48", 'u', 6}, {"UNSIGNED56", 'u', 7},
    {"UNSIGNED64", 'u', 8},     {"REAL32", 'f', 4},       {"REAL64", 'f', 8},     {"VISIBLE_STRING", 's', 0},
    {"UNICODE_STRING", 'a', 0}, {"OCTET_STRING", 'a', 0}, {"DOMAIN", 'a', 0},
};

const TypeShape* shape_of(const std::string& type) {
  for (const TypeShape& t : kTypes) {
    if (t.name == type) return &t;
  }
  return nullptr;
}

// The value of `count` bits read as `type` (a PDO entry): numbers only.
std::optional<Value> pdo_number(const TypeShape& t, std::uint64_t raw, unsigned count) {
  switch (t.kind) {
    case 'b': return Value(raw != 0);
    case 'i': return Value(sign_extend(raw, count));
    case 'u': return Value(raw);
    case 'f':
      if (count == 32) {
        float f;
        auto u = std::uint32_t(raw);
        std::memcpy(&f, &u, 4);
        return Value(double(f));
      }
      if (count == 64) {
        double d;
        std::memcpy(&d, &raw, 8);
        return Value(d);
      }
      return std::nullopt;
  }
  return std::nullopt;
}

double as_double(const Value& v) {
  return std::visit(
      [](const auto& x) -> double {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_arithmetic_v<T>) return double(x);
        return NAN;
      },
      v);
}

// 10^-d scales: the decimals to print (0x6132 of an integer PV); -1 otherwise.
int decimals_of(double scale) {
  if (scale >= 1.0 || scale <= 0.0) return -1;
  int d = int(std::lround(-std::log10(scale)));
  return d > 0 && d <= 18 && std::fabs(scale * std::pow(10.0, d) - 1.0) < 1e-9 ? d : -1;
}

DecodedField text_field(std::string name, std::string value, bool bare = false) {
  DecodedField f;
  f.name = std::move(name);
  f.value = Value(std::move(value));
  f.bare = bare;
  return f;
}

DecodedField number_field(std::string name, std::uint64_t value) {
  DecodedField f;
  f.name = std::move(name);
  f.value = Value(value);
  return f;
}

// A code or an identifier: hex in text ("0x06020000"), a number in JSON.
DecodedField hex_field(std::string name, std::uint64_t value, int digits) {
  DecodedField f = number_field(std::move(name), value);
  f.style = IntegerStyle::kHex;
  f.hex_digits = digits;
  return f;
}

DecodedField bytes_field(std::string name, const std::uint8_t* data, std::size_t n) {
  DecodedField f;
  f.name = std::move(name);
  f.value = Value(Bytes(data, data + n));
  return f;
}

std::string hex_text(std::uint64_t v, int digits) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%0*llX", digits, static_cast<unsigned long long>(v));
  return buf;
}

void raw(const RawFrame& f, DecodedFrame& out) {
  out.kind = "raw";
  out.fields.clear();
  if (f.rtr) out.fields.push_back(text_field("request", "RTR", true));
  out.fields.push_back(bytes_field("data", f.data, f.rtr ? 0 : f.dlc));
}

void decode_nmt(const RawFrame& f, DecodedFrame& out) {
  out.kind = "NMT";
  const std::string_view command = f.dlc >= 1 ? nmt_command_name(f.data[0]) : "";
  out.fields.push_back(text_field("command", command.empty() ? hex_text(f.data[0], 2) : std::string(command), true));
  if (f.dlc >= 2) {
    DecodedField target = hex_field("node-ID", f.data[1], 2);
    if (f.data[1] == kNmtAllNodes) target.value = Value(std::string("all"));
    out.fields.push_back(std::move(target));
  }
}

void decode_heartbeat(const RawFrame& f, DecodedFrame& out) {
  out.kind = "heartbeat";
  if (f.rtr) {
    out.fields.push_back(text_field("request", "node guarding RTR", true));
    return;
  }
  if (f.dlc < 1) return raw(f, out);
  const std::uint8_t state = f.data[0] & kNmtStateBits;
  if (state == std::uint8_t(NmtState::kInitialising)) {
    out.kind = "boot-up";
    return;
  }
  const std::string_view name = nmt_state_name(state);
  out.fields.push_back(text_field("state", name.empty() ? hex_text(state, 2) : std::string(name), true));
  if (f.data[0] & kGuardingToggle) out.fields.push_back(number_field("toggle", 1));
}

void decode_emcy(const RawFrame& f, const std::string& meaning, DecodedFrame& out) {
  out.kind = "EMCY";
  if (f.dlc < 3) return raw(f, out);
  const auto code = std::uint16_t(little_endian(f.data, 2));
  out.fields.push_back(hex_field("code", code, 4));
  out.fields.push_back(text_field("meaning", meaning));
  out.fields.push_back(hex_field("register", f.data[2], 2));
  if (f.dlc > 3) out.fields.push_back(bytes_field("vendor", f.data + 3, f.dlc - 3u));
}

void decode_sync(const RawFrame& f, DecodedFrame& out) {
  out.kind = "SYNC";
  if (f.dlc >= 1) out.fields.push_back(number_field("counter", f.data[0]));
}

void decode_lss(const RawFrame& f, DecodedFrame& out) {
  out.kind = "LSS";
  if (f.dlc < 1) return raw(f, out);
  const std::uint8_t cs = f.data[0];
  const std::string_view name = lss_command_name(cs);
  std::string what = name.empty() ? hex_text(cs, 2) : std::string(name);
  const bool reply = f.id == cob::kLssToMaster;
  out.fields.push_back(text_field("command", what + (reply ? " (response)" : ""), true));
  if (f.dlc < 8) return;
  switch (cs) {
    case lss::kSwitchGlobal:
      out.fields.push_back(text_field("mode", f.data[1] == lss::kModeWaiting ? "waiting" : "configuration"));
      break;
    case lss::kConfigureNodeId:
      if (reply) out.fields.push_back(number_field("error", f.data[1]));
      else out.fields.push_back(hex_field("node-ID", f.data[1], 2));
      break;
    case lss::kInquireNodeId:
      if (reply) out.fields.push_back(hex_field("node-ID", f.data[1], 2));
      break;
    case lss::kConfigureBitTiming:
      if (!reply) out.fields.push_back(number_field("table index", f.data[2]));
      else out.fields.push_back(number_field("error", f.data[1]));
      break;
    case lss::kActivateBitTiming:
      out.fields.push_back(number_field("switch delay ms", little_endian(f.data + 1, 2)));
      break;
    case lss::kStoreConfiguration:
      if (reply) out.fields.push_back(number_field("error", f.data[1]));
      break;
    default:
      if ((cs >= lss::kSelectiveVendor && cs <= lss::kIdentifySerialHigh) ||
          (cs >= lss::kInquireVendor && cs <= lss::kInquireSerial))
        out.fields.push_back(hex_field("value", little_endian(f.data + 1, 4), 8));
      break;
  }
}

std::string two_digit_hex(unsigned v) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%02X", v);
  return buf;
}

std::string clock_text(double t) {
  const auto whole = std::time_t(std::floor(t));
  const auto micros = int(std::lround((t - double(whole)) * 1e6));
  std::tm tm{};
  localtime_r(&whole, &tm);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%02d:%02d:%02d.%06d", tm.tm_hour, tm.tm_min, tm.tm_sec, std::min(micros, 999999));
  return buf;
}

}  // namespace

DecodedField object_field(const ObjectInfo& o, const Value& raw) {
  DecodedField f;
  f.name = o.name;
  f.index = o.index;
  f.sub = o.sub;
  f.value = f.raw = raw;
  f.unit = o.unit;
  const double x = as_double(raw);
  if (o.unit == kCountsUnit && !std::isnan(x)) {
    f.counts = x * o.scale;
    f.value = Value(o.engineering ? x * o.engineering->scale + o.engineering->offset : *f.counts);
    f.unit = o.engineering ? o.engineering->unit : kCountsUnit;
    return f;
  }
  if (o.scale == 1.0 || std::isnan(x)) return f;
  f.decimals = decimals_of(o.scale);
  f.value = Value(f.decimals > 0 ? x / std::pow(10.0, f.decimals) : x * o.scale);
  return f;
}

std::string format_field_value(const DecodedField& f) {
  if (!f.value) return "-";
  if (f.decimals > 0) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", f.decimals, as_double(*f.value));
    return buf;
  }
  if (const auto* b = std::get_if<Bytes>(&*f.value)) return b->empty() ? "-" : format_bytes(*b);
  if (const auto* u = std::get_if<std::uint64_t>(&*f.value); u && f.style == IntegerStyle::kHex)
    return hex_text(*u, f.hex_digits);
  if (const auto* d = std::get_if<double>(&*f.value)) return format_measure(*d);
  return format_value(*f.value, f.style);
}

Json field_json(const DecodedField& f) {
  return {{"name", f.name},
          {"index", f.index ? Json(*f.index) : Json(nullptr)},
          {"sub", f.sub ? Json(*f.sub) : Json(nullptr)},
          {"value", f.value ? json_value(*f.value) : Json(nullptr)},
          {"unit", json_text_or_null(f.unit)},
          {"raw", f.raw ? json_value(*f.raw) : Json(nullptr)},
          {"counts", f.counts ? json_number(*f.counts) : Json(nullptr)}};
}

Value typed_bytes(const std::string& type, const Bytes& data) {
  const TypeShape* t = shape_of(type);
  if (!t) return data;
  if (t->kind == 's')
    return std::string(data.begin(), std::find_if(data.rbegin(), data.rend(), [](std::uint8_t c) {
                                       return c != 0;
                                     }).base());  // without NUL padding
  if (t->kind == 'a' || data.size() < t->bytes || data.empty()) return data;
  const std::uint64_t raw = little_endian(data.data(), t->bytes);
  auto v = pdo_number(*t, raw, t->bytes * 8);
  return v ? *v : Value(data);
}

void FrameDecoder::set_node(NodeInfo node) {
  std::string key = node.key;
  auto it = nodes_.find(key);
  if (it != nodes_.end()) {
    unindex(it->second);
    it->second = std::move(node);
  } else {
    it = nodes_.emplace(key, std::move(node)).first;
  }
  index(it->second);
}

void FrameDecoder::remove_node(const std::string& key) {
  auto it = nodes_.find(key);
  if (it == nodes_.end()) return;
  unindex(it->second);
  nodes_.erase(it);
  sdo_.erase(key);
}

NodeInfo* FrameDecoder::node(const std::string& key) {
  auto it = nodes_.find(key);
  return it == nodes_.end() ? nullptr : &it->second;
}

// One node's entries in the indexes, added or taken out: a node costs what
// its own PDOs cost, whatever the fleet's size.
void FrameDecoder::index(const NodeInfo& n) {
  key_by_id_[{n.interface, n.node_id}].insert(n.key);
  for (std::size_t i = 0; i < n.pdos.size(); ++i)
    if (n.pdos[i].valid) pdo_by_id_[{n.interface, n.pdos[i].cob_id}].emplace(n.key, i);
}

void FrameDecoder::unindex(const NodeInfo& n) {
  const auto forget = [&](auto& index, const auto& id) {
    auto it = index.find(id);
    if (it == index.end()) return;
    it->second.erase(n.key);
    if (it->second.empty()) index.erase(it);
  };
  forget(key_by_id_, std::make_pair(n.interface, n.node_id));
  for (const PdoInfo& p : n.pdos)
    if (p.valid) forget(pdo_by_id_, std::make_pair(n.interface, p.cob_id));
}

NodeInfo* FrameDecoder::by_id(const std::string& interface, std::uint8_t node_id) {
  auto it = key_by_id_.find({interface, node_id});
  return it == key_by_id_.end() ? nullptr : node(*it->second.begin());
}

void FrameDecoder::load(NodeInfo& n) {
  if ((!n.objects || !n.emcy_codes) && loader_) loader_(n);
}

// The device's meaning of the code, else CiA 301's.
std::string FrameDecoder::emcy_text(NodeInfo& n, std::uint16_t code) {
  load(n);
  if (n.emcy_codes)
    if (auto it = n.emcy_codes->find(code); it != n.emcy_codes->end()) return it->second;
  return emcy_meaning(code);
}

const ObjectInfo* FrameDecoder::object(NodeInfo& n, std::uint16_t index, std::uint8_t sub) {
  load(n);
  if (!n.objects) return nullptr;
  for (const ObjectInfo& o : *n.objects) {
    if (o.index == index && o.sub == sub) return &o;
  }
  return nullptr;
}

DecodedFrame FrameDecoder::decode(const RawFrame& f) {
  DecodedFrame out = decode_canopen(f);
  if (!plant_signals_.empty()) add_plant_fields(f, out);
  return out;
}

void FrameDecoder::add_plant_fields(const RawFrame& f, DecodedFrame& out) const {
  CanFrame frame;
  frame.id = f.id;
  frame.dlc = f.dlc;
  frame.flags = std::uint8_t((f.extended ? CanFrame::kExtended : 0) | (f.rtr ? CanFrame::kRtr : 0));
  std::memcpy(frame.data, f.data, 8);
  bool first = true;
  for (const PlantSignalInfo& p : plant_signals_) {
    if (p.interface != f.interface || !p.signal.matches(frame)) continue;
    const std::optional<double> v = p.signal.value(frame);
    if (!v) continue;
    if (first && out.kind == "raw") {  // a frame no node owns: the controller's command
      out.kind = "plant";
      out.fields.clear();
    }
    first = false;
    DecodedField field;
    field.name = p.plant + "." + p.input;
    field.value = Value(*v);
    field.unit = p.unit;
    out.fields.push_back(std::move(field));
  }
}

DecodedFrame FrameDecoder::decode_canopen(const RawFrame& f) {
  DecodedFrame out;
  out.time = f.time;
  out.simulated_time = f.simulated_time;
  out.interface = f.interface;
  out.id = f.id;
  out.extended = f.extended;
  out.rtr = f.rtr;
  out.dlc = f.dlc;
  if (!f.rtr) out.data.assign(f.data, f.data + std::min<std::uint8_t>(f.dlc, 8));
  const std::uint32_t cob_id = f.id | (f.extended ? cob::kFrame29Bit : 0);
  if (auto it = pdo_by_id_.find({f.interface, cob_id}); it != pdo_by_id_.end()) {
    const auto& [key, pdo] = *it->second.begin();
    NodeInfo& n = nodes_.at(key);
    decode_pdo(n, n.pdos[pdo], f, out);
    return out;
  }
  if (f.extended) {
    raw(f, out);
    return out;
  }
  auto attach = [&](NodeInfo* n) {
    if (!n) return false;
    out.node = n->key;
    out.label = n->label;
    return true;
  };
  const std::uint8_t node_id = cob::node_id_of(f.id);
  const std::uint32_t function = cob::function_code(f.id);
  if (f.id == cob::kNmt) {
    if (f.dlc >= 2 && f.data[1] != kNmtAllNodes) attach(by_id(f.interface, f.data[1]));
    decode_nmt(f, out);
  } else if (f.id == cob::kSync) {
    decode_sync(f, out);
  } else if (f.id == cob::kLssFromMaster || f.id == cob::kLssToMaster) {
    decode_lss(f, out);
  } else if (node_id == 0 || !attach(by_id(f.interface, node_id))) {
    raw(f, out);
  } else if (function == cob::kEmcyBase) {
    decode_emcy(f, f.dlc >= 2 ? emcy_text(*node(out.node), std::uint16_t(little_endian(f.data, 2))) : "", out);
  } else if (function == cob::kErrorControlBase) {
    decode_heartbeat(f, out);
  } else if (function == cob::kSdoTxBase || function == cob::kSdoRxBase) {
    decode_sdo(*node(out.node), function == cob::kSdoRxBase, f, out);
  } else {
    out.node.clear();
    out.label.clear();
    raw(f, out);
  }
  return out;
}

void FrameDecoder::decode_pdo(NodeInfo& n, const PdoInfo& pdo, const RawFrame& f, DecodedFrame& out) {
  out.node = n.key;
  out.label = n.label;
  out.kind = pdo.name;
  if (f.rtr) {
    out.fields.push_back(text_field("request", "RTR", true));
    return;
  }
  unsigned first = 0;
  for (const PdoEntryInfo& e : pdo.entries) {
    const unsigned end = first + e.bits;
    if (end > f.dlc * 8u) {
      out.fields.push_back(text_field("error", "frame too short for the mapping (DLC " + std::to_string(f.dlc) + ")"));
      return;
    }
    if (!e.object.name.empty()) {
      const std::uint64_t raw_bits = bit_field(f.data, first, e.bits);
      const TypeShape* t = shape_of(e.object.type);
      auto v = t ? pdo_number(*t, raw_bits, e.bits) : std::nullopt;
      if (v) {
        out.fields.push_back(object_field(e.object, *v));
      } else {
        DecodedField raw_field = hex_field(e.object.name, raw_bits, (e.bits + 3) / 4);
        raw_field.index = e.object.index;
        raw_field.sub = e.object.sub;
        out.fields.push_back(std::move(raw_field));
      }
    }
    first = end;
  }
}

void FrameDecoder::sdo_value(NodeInfo& n, std::uint16_t index, std::uint8_t sub, const Bytes& data, DecodedFrame& out) {
  const ObjectInfo* o = object(n, index, sub);
  DecodedField f;
  f.index = index;
  f.sub = sub;
  if (!o) {
    f.name = "object";
    f.value = Value(data);
    out.fields.push_back(std::move(f));
    return;
  }
  DecodedField field = object_field(*o, typed_bytes(o->type, data));
  if (written_in_hex(index, sub) && field.value && std::holds_alternative<std::uint64_t>(*field.value)) {
    field.style = IntegerStyle::kHex;
    field.hex_digits = int(2 * std::min<std::size_t>(data.size(), 8));
  }
  out.fields.push_back(std::move(field));
}

void FrameDecoder::decode_sdo(NodeInfo& n, bool request, const RawFrame& f, DecodedFrame& out) {
  out.kind = "SDO";
  if (f.dlc != 8) {
    out.fields.push_back(text_field("error", "DLC " + std::to_string(f.dlc) + ", expected 8"));
    return;
  }
  const std::uint8_t cmd = f.data[0];
  const std::uint8_t cs = cmd & sdo::kCsMask;
  const auto index = std::uint16_t(little_endian(f.data + 1, 2));
  const std::uint8_t sub = f.data[3];
  SdoTransfer& transfer = sdo_[n.key];
  auto command = [&](const char* what) { out.fields.push_back(text_field("command", what, true)); };
  auto object_only = [&] {
    const ObjectInfo* o = object(n, index, sub);
    DecodedField field;
    field.name = o ? o->name : "object";
    field.index = index;
    field.sub = sub;
    out.fields.push_back(std::move(field));
  };
  // Initiate with e (expedited) / s (size indicated) / n (unused bytes): the value, or the size that follows.
  auto initiate = [&](bool upload) {
    const bool expedited = cmd & sdo::kExpedited, sized = cmd & sdo::kSizeIndicated;
    if (expedited) {
      const unsigned bytes = sized ? sdo::expedited_bytes(cmd) : 4;
      sdo_value(n, index, sub, Bytes(f.data + 4, f.data + 4 + bytes), out);
      transfer.active = false;
      return;
    }
    object_only();
    if (sized) out.fields.push_back(number_field("size", little_endian(f.data + 4, 4)));
    transfer = {upload, index, sub, {}, true};
  };
  // A segment: 7 - n data bytes; c (bit 0) ends the transfer, whose value is then printed whole.
  auto segment = [&](bool upload) {
    const unsigned bytes = sdo::segment_bytes(cmd);
    const bool last = cmd & sdo::kLastSegment;
    if (!transfer.active || transfer.upload != upload) {
      out.fields.push_back(bytes_field("data", f.data + 1, bytes));
      return;
    }
    transfer.data.insert(transfer.data.end(), f.data + 1, f.data + 1 + bytes);
    if (!last) {
      out.fields.push_back(number_field("bytes so far", transfer.data.size()));
      return;
    }
    transfer.active = false;
    sdo_value(n, transfer.index, transfer.sub, transfer.data, out);
  };
  if (cs == sdo::kCsAbort) {
    command("abort");
    object_only();
    const auto code = std::uint32_t(little_endian(f.data + 4, 4));
    out.fields.push_back(hex_field("code", code, 8));
    const std::string_view meaning = sdo_abort_meaning(code);
    out.fields.push_back(text_field("abort", meaning.empty() ? "unknown" : std::string(meaning)));
    transfer.active = false;
    return;
  }
  if (request) {
    switch (cs) {
      case sdo::kCcsInitiateDownload: command("download request"); return initiate(false);
      case sdo::kCcsDownloadSegment: command("download segment"); return segment(false);
      case sdo::kCcsInitiateUpload:
        command("upload request");
        transfer = {true, index, sub, {}, false};
        return object_only();
      case sdo::kCcsUploadSegment: return command("upload segment request");
      case sdo::kCcsBlockUpload: command("block upload request"); return object_only();
      case sdo::kCcsBlockDownload: command("block download request"); return object_only();
    }
  } else {
    switch (cs) {
      case sdo::kScsInitiateUpload: command("upload response"); return initiate(true);
      case sdo::kScsUploadSegment: command("upload segment"); return segment(true);
      case sdo::kScsInitiateDownload:
        // A device answering reads with 0x60 + the value (Honeywell DPS, Table 19).
        if (!transfer.active && transfer.upload && transfer.index == index && transfer.sub == sub) {
          command("upload response");
          return sdo_value(n, index, sub, Bytes(f.data + 4, f.data + 8), out);
        }
        command("download response");
        return object_only();
      case sdo::kScsDownloadSegment: return command("download segment response");
      case sdo::kScsBlockUpload: return command("block upload response");
      case sdo::kScsBlockDownload: return command("block download response");
    }
  }
  command("unknown command");
  out.fields.push_back(hex_field("specifier", cmd, 2));
}

std::string format_decoded(const DecodedFrame& f) {
  std::string line = clock_text(f.time) + " " + f.interface + " ";
  line += f.extended ? hex_text(f.id, 8).substr(2) : hex_text(f.id, 3).substr(2);
  line += " " + (f.label.empty() ? std::string("-") : f.label) + " " + f.kind;
  bool first = true, after_bare = false;
  for (const DecodedField& field : f.fields) {
    // "SDO upload response 0x1018:04 Serial number = 1", "NMT start, node-ID = all"
    line += first || (after_bare && field.index) ? " " : ", ";
    first = false;
    after_bare = field.bare;
    std::string value = format_field_value(field);
    if (!field.unit.empty() && field.value) value += " " + field.unit;
    if (field.counts && field.unit != kCountsUnit) value = format_measure(*field.counts) + " counts (" + value + ")";
    std::string name = field.name;
    if (field.index && f.kind == "SDO")
      name = hex_text(*field.index, 4) + ":" + two_digit_hex(field.sub.value_or(0)) + " " + name;
    line += field.bare ? value : (field.value ? name + " = " + value : name);
  }
  return line;
}

Json decoded_json(const DecodedFrame& f) {
  Json fields = Json::array();
  for (const DecodedField& field : f.fields) fields.push_back(field_json(field));
  return {{"time", f.simulated_time ? json_number(*f.simulated_time) : Json(nullptr)},
          {"wall_time", f.time},
          {"interface", f.interface},
          {"id", f.id},
          {"extended", f.extended},
          {"rtr", f.rtr},
          {"dlc", f.dlc},
          {"data", json_value(f.data)},
          {"node", json_text_or_null(f.node)},
          {"kind", f.kind},
          {"fields", std::move(fields)}};
}

}  // namespace cansim::ctl
