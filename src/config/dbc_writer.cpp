#include "config/dbc_writer.hpp"

#include <charconv>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "core/protocol.hpp"

namespace cansim::config {

namespace {

constexpr std::uint32_t kDbcExtended = 0x80000000u;  // DBC: bit 31 of a BO_ id marks a 29-bit CAN-ID
constexpr const char* kMaster = "Master";

// The shortest text that reads back as d ("0.01", not "0.01000000000000000021").
std::string number(double d) {
  char buf[64];
  auto r = std::to_chars(buf, buf + sizeof buf, d);
  return std::string(buf, r.ptr);
}

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) out += c == '"' ? '\'' : c;
  return out + "\"";
}

struct Signal {
  std::string name;
  unsigned start = 0, bits = 0;
  bool is_signed = false;
  int float_type = 0;                 // SIG_VALTYPE_: 1 IEEE float, 2 IEEE double
  double factor = 1.0, offset = 0.0;  // physical value = raw x factor + offset
  double min = 0, max = 0;
  std::string unit;
  std::string receiver = kMaster;
  std::string comment;
  std::vector<std::pair<std::int64_t, std::string>> values;  // VAL_
};

struct Message {
  std::uint32_t id = 0;  // with kDbcExtended for 29-bit
  std::string name;
  unsigned dlc = 0;
  std::string transmitter;
  std::string comment;
  std::vector<Signal> signals;
};

// raw x factor, exact for 10^-d factors (32767 x 0.1 is 3276.7, not 3276.7000000000003).
double engineering(double raw, double factor) {
  const double decimals = std::round(-std::log10(factor));
  if (factor < 1.0 && decimals > 0 && std::fabs(factor * std::pow(10.0, decimals) - 1.0) < 1e-9)
    return raw / std::pow(10.0, decimals);
  return raw * factor;
}

// The raw range of `bits` bits of a type, or of the entry's own limits.
void raw_range(const OdEntry& e, unsigned bits, double& lo, double& hi) {
  if (is_real(e.type)) {
    hi = bits == 64 ? std::numeric_limits<double>::max() : double(std::numeric_limits<float>::max());
    lo = -hi;
    return;
  }
  const bool sign = is_signed(e.type);
  lo = sign ? -std::ldexp(1.0, int(bits) - 1) : 0.0;
  hi = sign ? std::ldexp(1.0, int(bits) - 1) - 1 : std::ldexp(1.0, int(bits)) - 1;
  if (bits != type_size(e.type) * 8) return;
  if (e.has_low) lo = sign ? double(decode_i(e.type, e.low)) : double(decode_u(e.type, e.low));
  if (e.has_high) hi = sign ? double(decode_i(e.type, e.high)) : double(decode_u(e.type, e.high));
}

std::string hex(std::uint32_t v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*" PRIX32, digits, v);
  return buf;
}

// A name not yet in `taken` (name, name_2, name_3, ...).
std::string unique(std::string name, std::set<std::string>& taken) {
  std::string candidate = name;
  for (int n = 2; !taken.insert(candidate).second; ++n) candidate = name + "_" + std::to_string(n);
  return candidate;
}

Message pdo_message(const DbcNode& n, const std::string& node_name, const personalities::PdoView& p) {
  Message m;
  m.id = p.can_id | (p.extended ? kDbcExtended : 0);
  m.name = node_name + "_" + p.name();
  m.dlc = (p.bits + 7u) / 8u;
  m.transmitter = p.transmit ? node_name : kMaster;
  m.comment =
      p.name() + " of " + n.label + " (" + n.key + "), transmission type " + std::to_string(p.transmission_type);
  std::set<std::string> taken;
  unsigned start = 0;
  for (const personalities::PdoEntryView& e : p.entries) {
    if (e.entry) {
      Signal s;
      s.name = unique(dbc_identifier(e.entry->name), taken);
      s.start = start;
      s.bits = e.bits;
      s.is_signed = is_signed(e.entry->type) || is_real(e.entry->type);
      if (is_real(e.entry->type)) s.float_type = e.bits == 64 ? 2 : 1;
      s.factor = e.meaning.scale;
      s.offset = e.meaning.offset;
      double lo = 0, hi = 0;
      raw_range(*e.entry, e.bits, lo, hi);
      s.min = engineering(lo, s.factor) + s.offset;
      s.max = engineering(hi, s.factor) + s.offset;
      if (s.min > s.max) std::swap(s.min, s.max);
      s.unit = e.meaning.unit;
      s.receiver = p.transmit ? kMaster : node_name;
      char where[16];
      std::snprintf(where, sizeof where, "0x%04X:%02X", e.index, e.sub);
      s.comment = std::string(where) + " " + e.entry->name + " (" + type_name(e.entry->type) + ")";
      if (e.meaning.counts)
        s.comment += "; the device sends counts" +
                     (e.meaning.count_scale != 1.0 ? " (raw x " + number(e.meaning.count_scale) + ")" : "") +
                     ": factor and offset are its own scaling";
      m.signals.push_back(std::move(s));
    }
    start += e.bits;
  }
  return m;
}

Message heartbeat_message(const DbcNode& n, const std::string& node_name) {
  Message m{cob::kErrorControlBase + n.node_id,
            node_name + "_heartbeat",
            1,
            node_name,
            "heartbeat / boot-up (state 0) of " + n.label + " (node-ID " + hex(n.node_id, 2) + ")",
            {}};
  Signal state{"NMT_state", 0, 7, false, 0, 1.0, 0, 0, 127, "", kMaster, "CiA 301 §7.2.8.3.2", {}};
  state.values = {{std::int64_t(NmtState::kInitialising), "boot-up"},
                  {std::int64_t(NmtState::kStopped), "stopped"},
                  {std::int64_t(NmtState::kOperational), "operational"},
                  {std::int64_t(NmtState::kPreOperational), "pre-operational"}};
  m.signals.push_back(std::move(state));
  m.signals.push_back({"toggle", 7, 1, false, 0, 1.0, 0, 0, 1, "", kMaster, "node guarding toggle bit", {}});
  return m;
}

Message emcy_message(const DbcNode& n, const std::string& node_name) {
  Message m{cob::kEmcyBase + n.node_id, node_name + "_EMCY", 8, node_name, "EMCY of " + n.label, {}};
  Signal code{"error_code",
              0,
              16,
              false,
              0,
              1.0,
              0,
              0,
              65535,
              "",
              kMaster,
              "CiA 301 Table 21; the values as the device's manual names them",
              {}};
  code.values.emplace_back(0, "error reset / no error");
  for (const auto& [c, meaning] : n.emcy_codes)
    if (c != 0) code.values.emplace_back(c, meaning);
  m.signals.push_back(std::move(code));
  m.signals.push_back({"error_register", 16, 8, false, 0, 1.0, 0, 0, 255, "", kMaster, "0x1001", {}});
  m.signals.push_back(
      {"vendor", 24, 40, false, 0, 1.0, 0, 0, 1099511627775.0, "", kMaster, "manufacturer-specific", {}});
  return m;
}

std::vector<Message> bus_messages() {
  Message nmt{cob::kNmt, "NMT", 2, kMaster, "NMT node control (CiA 301 §7.2.8.3.1)", {}};
  Signal command{"command", 0, 8, false, 0, 1.0, 0, 0, 255, "", "", "", {}};
  command.values = {{kNmtStart, "start"},
                    {kNmtStop, "stop"},
                    {kNmtEnterPreOperational, "enter pre-operational"},
                    {kNmtResetNode, "reset node"},
                    {kNmtResetCommunication, "reset communication"}};
  nmt.signals.push_back(std::move(command));
  nmt.signals.push_back({"node_id", 8, 8, false, 0, 1.0, 0, 0, 127, "", "", "0: all nodes", {}});
  Message sync{cob::kSync, "SYNC", 0, kMaster, "SYNC (CiA 301 §7.2.5)", {}};
  return {std::move(nmt), std::move(sync)};
}

void write_message(std::ostringstream& out, const Message& m) {
  out << "\nBO_ " << m.id << " " << m.name << ": " << m.dlc << " " << m.transmitter << "\n";
  for (const Signal& s : m.signals) {
    out << " SG_ " << s.name << " : " << s.start << "|" << s.bits << "@1" << (s.is_signed ? "-" : "+") << " ("
        << number(s.factor) << "," << number(s.offset) << ") [" << number(s.min) << "|" << number(s.max) << "] "
        << quoted(s.unit) << " " << (s.receiver.empty() ? "Vector__XXX" : s.receiver) << "\n";
  }
}

}  // namespace

std::string dbc_identifier(const std::string& name) {
  std::string out;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
    if (ok) out += c;
    else if (!out.empty() && out.back() != '_') out += '_';
  }
  while (!out.empty() && out.back() == '_') out.pop_back();
  if (out.empty() || (out[0] >= '0' && out[0] <= '9')) out = "n" + out;
  return out;
}

std::string write_dbc(const DbcBus& bus) {
  std::vector<Message> messages = bus_messages();
  std::vector<std::string> node_names;
  std::set<std::string> taken_nodes{kMaster};
  std::set<std::uint32_t> ids{cob::kNmt, cob::kSync};
  std::vector<std::string> skipped;
  auto add = [&](Message m) {
    if (!ids.insert(m.id).second)
      return skipped.push_back(m.name + " (CAN-ID " + hex(m.id & ~kDbcExtended, 3) + " taken)");
    messages.push_back(std::move(m));
  };
  for (const DbcNode& n : bus.nodes) {
    const std::string name = unique(dbc_identifier(n.label), taken_nodes);
    node_names.push_back(name);
    for (const personalities::PdoView& p : n.pdos) {
      if (p.valid && !p.entries.empty()) add(pdo_message(n, name, p));
    }
    if (n.node_id >= 1 && n.node_id <= 127) {
      add(heartbeat_message(n, name));
      add(emcy_message(n, name));
    }
  }

  std::ostringstream out;
  out << "VERSION \"cansimd\"\n\n\nNS_ :\n\tNS_DESC_\n\tCM_\n\tBA_DEF_\n\tBA_\n\tVAL_\n\tSIG_VALTYPE_\n\nBS_:\n\nBU_: "
      << kMaster;
  for (const std::string& n : node_names) out << " " << n;
  out << "\n";
  for (const Message& m : messages) write_message(out, m);
  out << "\n";
  out << "CM_ \"CAN bus " << bus.name << " of a cansimd fleet (" << bus.nodes.size()
      << " simulated node(s)): PDOs as configured at power-on";
  for (const std::string& s : skipped) out << "; not described: " << s;
  out << "\";\n";
  out << "CM_ BU_ " << kMaster << " \"the CANopen master (NMT, SYNC, RPDOs)\";\n";
  for (std::size_t i = 0; i < bus.nodes.size(); ++i) {
    const DbcNode& n = bus.nodes[i];
    out << "CM_ BU_ " << node_names[i] << " "
        << quoted(n.key + ", profile " + n.profile + ", node-ID " + hex(n.node_id, 2)) << ";\n";
  }
  for (const Message& m : messages) {
    if (!m.comment.empty()) out << "CM_ BO_ " << m.id << " " << quoted(m.comment) << ";\n";
    for (const Signal& s : m.signals)
      if (!s.comment.empty()) out << "CM_ SG_ " << m.id << " " << s.name << " " << quoted(s.comment) << ";\n";
  }
  out << "BA_DEF_  \"BusType\" STRING ;\n";
  out << "BA_DEF_  \"Baudrate\" INT 0 1000000;\n";
  out << "BA_DEF_DEF_  \"BusType\" \"CAN\";\n";
  out << "BA_DEF_DEF_  \"Baudrate\" 250000;\n";
  out << "BA_ \"BusType\" \"CAN\";\n";
  out << "BA_ \"Baudrate\" " << bus.bit_rate_kbit * 1000 << ";\n";
  for (const Message& m : messages) {
    for (const Signal& s : m.signals) {
      if (s.values.empty()) continue;
      out << "VAL_ " << m.id << " " << s.name;
      for (const auto& [v, text] : s.values) out << " " << v << " " << quoted(text);
      out << " ;\n";
    }
  }
  for (const Message& m : messages)
    for (const Signal& s : m.signals)
      if (s.float_type) out << "SIG_VALTYPE_ " << m.id << " " << s.name << " : " << s.float_type << ";\n";
  return out.str();
}

}  // namespace cansim::config
