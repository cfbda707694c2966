#include "ctl/decode.hpp"

#include <cstdlib>
#include <cstring>
#include <string_view>

#include "ctl/connection.hpp"
#include "ctl/output.hpp"

namespace cansim::ctl {

namespace {

[[noreturn]] void malformed(const std::string& what) { throw Failure("unexpected reply from cansimd: " + what); }

void expect(int r) {
  if (r < 0) malformed(std::strerror(-r));
}

// r of a read that must find a value: 0 means the container ended early.
void expect_value(int r) {
  expect(r);
  if (r == 0) malformed("a value is missing");
}

template <typename T>
T read_basic(sd_bus_message* m, char type) {
  T v{};
  expect_value(sd_bus_message_read_basic(m, type, &v));
  return v;
}

std::string read_string(sd_bus_message* m, char type = 's') { return read_basic<const char*>(m, type); }

bool read_bool(sd_bus_message* m) { return read_basic<int>(m, 'b') != 0; }

Bytes read_bytes(sd_bus_message* m) {
  const void* data = nullptr;
  std::size_t size = 0;
  expect(sd_bus_message_read_array(m, 'y', &data, &size));
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  return size ? Bytes(bytes, bytes + size) : Bytes();
}

void enter(sd_bus_message* m, char type, const char* contents) {
  expect_value(sd_bus_message_enter_container(m, type, contents));
}

void leave(sd_bus_message* m) { expect(sd_bus_message_exit_container(m)); }

bool at_end(sd_bus_message* m) {
  int r = sd_bus_message_at_end(m, 0);
  expect(r);
  return r > 0;
}

// An array whose elements (of signature element) read_one reads.
template <typename ReadOne>
auto read_array(sd_bus_message* m, const char* element, ReadOne read_one) {
  enter(m, 'a', element);
  std::vector<decltype(read_one(m))> out;
  while (!at_end(m)) out.push_back(read_one(m));
  leave(m);
  return out;
}

bool is_basic(char type) { return type != '\0' && std::strchr("ybnqiuxtdsog", type); }

Value read_basic_value(sd_bus_message* m, char type) {
  switch (type) {
    case 'b': return read_bool(m);
    case 'y': return read_basic<std::uint8_t>(m, type);
    case 'n': return read_basic<std::int16_t>(m, type);
    case 'q': return read_basic<std::uint16_t>(m, type);
    case 'i': return read_basic<std::int32_t>(m, type);
    case 'u': return read_basic<std::uint32_t>(m, type);
    case 'x': return read_basic<std::int64_t>(m, type);
    case 't': return read_basic<std::uint64_t>(m, type);
    case 'd': return read_basic<double>(m, type);
    default: return read_string(m, type);  // s, o, g
  }
}

struct PeekedType {
  char type = 0;
  std::string contents;
};

PeekedType peek(sd_bus_message* m) {
  char type = 0;
  const char* contents = nullptr;
  expect_value(sd_bus_message_peek_type(m, &type, &contents));
  return {type, contents ? contents : ""};
}

// ---------------------------------------------------------------- node properties

Reading read_reading(sd_bus_message* m) {
  Reading r;
  const char* unit = "";
  expect_value(sd_bus_message_read(m, "(ddsy)", &r.true_value, &r.reported, &unit, &r.status));
  r.unit = unit;
  return r;
}

OverrideRow read_override(sd_bus_message* m) {
  OverrideRow o;
  const char *channel = "", *unit = "";
  expect_value(sd_bus_message_read(m, "(sds)", &channel, &o.value, &unit));
  o.channel = channel;
  o.unit = unit;
  return o;
}

FaultBrief read_fault_brief(sd_bus_message* m) {
  FaultBrief f;
  const char* kind = "";
  int active = 0;
  expect_value(sd_bus_message_read(m, "(usb)", &f.id, &kind, &active));
  f.kind = kind;
  f.active = active;
  return f;
}

EmcyRecord read_emcy(sd_bus_message* m) {
  EmcyRecord e;
  enter(m, 'r', "xqyay");
  expect_value(sd_bus_message_read(m, "xqy", &e.time_us, &e.code, &e.error_register));
  e.vendor = read_bytes(m);
  leave(m);
  return e;
}

struct PropertyReader {
  std::string_view name;
  std::string_view signature;
  void (*read)(sd_bus_message*, NodeStatus&);
};

constexpr PropertyReader kNodeProperties[] = {
    {"Key", "s", [](sd_bus_message* m, NodeStatus& s) { s.key = read_string(m); }},
    {"Name", "s", [](sd_bus_message* m, NodeStatus& s) { s.name = read_string(m); }},
    {"Index", "u", [](sd_bus_message* m, NodeStatus& s) { s.index = read_basic<std::uint32_t>(m, 'u'); }},
    {"Profile", "s", [](sd_bus_message* m, NodeStatus& s) { s.profile = read_string(m); }},
    {"Personality", "s", [](sd_bus_message* m, NodeStatus& s) { s.personality = read_string(m); }},
    {"Interface", "s", [](sd_bus_message* m, NodeStatus& s) { s.interface = read_string(m); }},
    {"NodeId", "y", [](sd_bus_message* m, NodeStatus& s) { s.node_id = read_basic<std::uint8_t>(m, 'y'); }},
    {"NmtState", "s", [](sd_bus_message* m, NodeStatus& s) { s.nmt_state = read_string(m); }},
    {"Powered", "b", [](sd_bus_message* m, NodeStatus& s) { s.powered = read_bool(m); }},
    {"OnBus", "b", [](sd_bus_message* m, NodeStatus& s) { s.on_bus = read_bool(m); }},
    {"Pressure", "(ddsy)",
     [](sd_bus_message* m, NodeStatus& s) {
       const double counts = s.pressure.counts;  // the properties come in any order
       s.pressure = read_reading(m);
       s.pressure.counts = counts;
     }},
    {"Temperature", "(ddsy)",
     [](sd_bus_message* m, NodeStatus& s) {
       const double counts = s.temperature.counts;
       s.temperature = read_reading(m);
       s.temperature.counts = counts;
     }},
    {"PressureCounts", "d", [](sd_bus_message* m, NodeStatus& s) { s.pressure.counts = read_basic<double>(m, 'd'); }},
    {"TemperatureCounts", "d",
     [](sd_bus_message* m, NodeStatus& s) { s.temperature.counts = read_basic<double>(m, 'd'); }},
    {"Overrides", "a(sds)",
     [](sd_bus_message* m, NodeStatus& s) { s.overrides = read_array(m, "(sds)", read_override); }},
    {"Faults", "a(usb)", [](sd_bus_message* m, NodeStatus& s) { s.faults = read_array(m, "(usb)", read_fault_brief); }},
    {"EmcyCount", "u", [](sd_bus_message* m, NodeStatus& s) { s.emcy_count = read_basic<std::uint32_t>(m, 'u'); }},
    {"LastEmcy", "(xqyay)", [](sd_bus_message* m, NodeStatus& s) { s.last_emcy = read_emcy(m); }},
    {"Recording", "s", [](sd_bus_message* m, NodeStatus& s) { s.recording = read_string(m); }},
    {"FramesSent", "t", [](sd_bus_message* m, NodeStatus& s) { s.frames_sent = read_basic<std::uint64_t>(m, 't'); }},
};

// One a{sv} entry: a known property of the expected type is read, any other skipped.
void read_node_property(sd_bus_message* m, NodeStatus& status) {
  enter(m, 'e', "sv");
  std::string name = read_string(m);
  std::string type = peek(m).contents;
  for (const PropertyReader& p : kNodeProperties) {
    if (p.name != name || p.signature != type) continue;
    enter(m, 'v', type.c_str());
    p.read(m, status);
    leave(m);
    return leave(m);
  }
  expect(sd_bus_message_skip(m, "v"));
  leave(m);
}

// ---------------------------------------------------------------- signals

struct ArgName {
  std::string_view name;
  IntegerStyle style = IntegerStyle::kDecimal;
};

struct SignalSpec {
  std::string_view name;
  bool timed;  // starts with the simulated time (x)
  std::vector<ArgName> args;
};

const std::vector<SignalSpec>& signal_specs() {
  constexpr auto kHex = IntegerStyle::kHex;
  static const std::vector<SignalSpec> kSpecs = {
      {"NmtStateChanged", true, {{"old"}, {"new"}}},
      {"BootUp", true, {{"node_id", kHex}}},
      {"EmcySent", true, {{"code", kHex}, {"register", kHex}, {"vendor"}}},
      {"ObjectWritten", true, {{"index", kHex}, {"sub"}, {"value"}, {"via"}}},
      {"FaultStarted", true, {{"id"}, {"kind"}}},
      {"FaultEnded", true, {{"id"}, {"kind"}}},
      {"NodeAdded", false, {{"path"}, {"key"}}},
      {"NodeRemoved", false, {{"path"}, {"key"}}},
  };
  return kSpecs;
}

const SignalSpec* find_signal(std::string_view name) {
  for (const SignalSpec& s : signal_specs()) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

// A signal argument or property value; what is neither basic, bytes nor the
// fault list prints as "…".
Value read_field(sd_bus_message* m) {
  PeekedType t = peek(m);
  if (t.type == 'v') {
    enter(m, 'v', t.contents.c_str());
    Value v = read_field(m);
    leave(m);
    return v;
  }
  if (t.type == 'a' && t.contents == "(usb)") return format_fault_briefs(read_array(m, "(usb)", read_fault_brief));
  if (t.type == 'a' && t.contents == "y") return read_value(m);
  if (is_basic(t.type)) return read_value(m);
  expect(sd_bus_message_skip(m, nullptr));
  return std::string("…");
}

void read_properties_changed(sd_bus_message* m, Event& e) {
  read_string(m);  // interface
  enter(m, 'a', "{sv}");
  while (!at_end(m)) {
    enter(m, 'e', "sv");
    std::string name = read_string(m);
    PeekedType t = peek(m);  // a variant
    if (t.contents == "a(usb)") {
      enter(m, 'v', "a(usb)");
      std::vector<FaultBrief> faults = read_array(m, "(usb)", read_fault_brief);
      leave(m);
      e.fields.push_back({name, format_fault_briefs(faults), IntegerStyle::kDecimal, faults});
    } else {
      e.fields.push_back({name, read_field(m)});
    }
    leave(m);
  }
  leave(m);
  for (const std::string& name : read_array(m, "s", [](sd_bus_message* m) { return read_string(m); }))
    e.fields.push_back({name, std::string("(changed)")});
}

std::string source_of(const char* path) {
  std::string p = path ? path : "";
  if (p == kFleetPath) return "fleet";
  std::string key = node_key_of_path(p);
  return key.empty() ? p : key;
}

}  // namespace

Value read_value(sd_bus_message* m) {
  PeekedType t = peek(m);
  if (t.type == 'v') {
    enter(m, 'v', t.contents.c_str());
    Value v = read_value(m);
    leave(m);
    return v;
  }
  if (t.type == 'a' && t.contents == "y") return read_bytes(m);
  if (is_basic(t.type)) return read_basic_value(m, t.type);
  malformed(std::string("a value of type ") + t.type + t.contents);
}

std::int64_t read_int64(sd_bus_message* m) {
  Value v = read_value(m);
  if (const auto* x = std::get_if<std::int64_t>(&v)) return *x;
  malformed(std::string("expected x, got ") + signature(v));
}

std::uint32_t read_uint32(sd_bus_message* m) { return read_basic<std::uint32_t>(m, 'u'); }

std::string read_object_path(sd_bus_message* m) { return read_string(m, 'o'); }
std::string read_text(sd_bus_message* m) { return read_string(m, 's'); }

std::vector<std::string> read_object_paths(sd_bus_message* m) { return read_array(m, "o", read_object_path); }

std::vector<NodeRow> read_node_rows(sd_bus_message* m) {
  return read_array(m, "(osssysss)", [](sd_bus_message* m) {
    const char *path, *key, *name, *interface, *profile, *personality, *state;
    NodeRow r;
    expect_value(sd_bus_message_read(m, "(osssysss)", &path, &key, &name, &interface, &r.node_id, &profile,
                                     &personality, &state));
    r.path = path, r.key = key, r.name = name, r.interface = interface;
    r.profile = profile, r.personality = personality, r.nmt_state = state;
    return r;
  });
}

std::vector<FaultRow> read_fault_rows(sd_bus_message* m) {
  return read_array(m, "(ussbxxxu)", [](sd_bus_message* m) {
    const char *kind, *channel;
    int active = 0;
    FaultRow f;
    expect_value(sd_bus_message_read(m, "(ussbxxxu)", &f.id, &kind, &channel, &active, &f.start_us, &f.duration_us,
                                     &f.period_us, &f.count));
    f.kind = kind, f.channel = channel, f.active = active;
    return f;
  });
}

std::vector<BusStats> read_bus_stats(sd_bus_message* m) {
  return read_array(m, "(sbuttttdd)", [](sd_bus_message* m) {
    const char* name;
    int up = 0;
    BusStats b;
    expect_value(sd_bus_message_read(m, "(sbuttttdd)", &name, &up, &b.bit_rate_kbit, &b.frames_in, &b.frames_out,
                                     &b.frames_dropped, &b.frames_offline, &b.offered_load, &b.measured_load));
    b.name = name, b.up = up;
    return b;
  });
}

namespace {
BusStats* row_of(std::vector<BusStats>& rows, const char* name) {
  for (BusStats& b : rows)
    if (b.name == name) return &b;
  return nullptr;
}
}  // namespace

void read_bus_load(sd_bus_message* m, std::vector<BusStats>& rows) {
  enter(m, 'v', "a(ssddddxxxxxuut)");
  read_array(m, "(ssddddxxxxxuut)", [&](sd_bus_message* m) {
    const char *name, *model;
    BusStats l;
    expect_value(sd_bus_message_read(m, "(ssddddxxxxxuut)", &name, &model, &l.offered_1s, &l.offered_10s, &l.carried_1s,
                                     &l.carried_10s, &l.delay_p50_us, &l.delay_p99_us, &l.delay_max_us, &l.slip_p99_us,
                                     &l.slip_max_us, &l.queued, &l.queue_capacity, &l.queue_dropped));
    if (BusStats* b = row_of(rows, name)) {
      l.name = b->name, l.up = b->up, l.bit_rate_kbit = b->bit_rate_kbit, l.frames_in = b->frames_in;
      l.frames_out = b->frames_out, l.frames_dropped = b->frames_dropped, l.frames_offline = b->frames_offline;
      // measured_load is by definition carried_load_10s: take it from this one sample, not GetStats' earlier one.
      l.offered_load = b->offered_load, l.measured_load = l.carried_10s, l.state = b->state, l.model = model;
      *b = l;
    }
    return 0;
  });
  leave(m);
}

void read_socketcand_buses(sd_bus_message* m, std::vector<BusStats>& rows) {
  enter(m, 'v', "a(ssqu)");
  read_array(m, "(ssqu)", [&](sd_bus_message* m) {
    const char *name, *host;
    std::uint16_t port = 0;
    std::uint32_t clients = 0;
    expect_value(sd_bus_message_read(m, "(ssqu)", &name, &host, &port, &clients));
    if (BusStats* b = row_of(rows, name))
      b->transport = "socketcand", b->listen_host = host, b->listen_port = port, b->clients = clients;
    return 0;
  });
  leave(m);
}

void read_bus_states(sd_bus_message* m, std::vector<BusStats>& rows) {
  enter(m, 'v', "a{ss}");
  read_array(m, "{ss}", [&](sd_bus_message* m) {
    const char *name, *state;
    expect_value(sd_bus_message_read(m, "{ss}", &name, &state));
    if (BusStats* b = row_of(rows, name)) b->state = state;
    return 0;
  });
  leave(m);
}

NodeStatus read_node_status(sd_bus_message* m) {
  NodeStatus status;
  enter(m, 'a', "{sv}");
  while (!at_end(m)) read_node_property(m, status);
  leave(m);
  return status;
}

std::vector<NodeStatus> read_managed_nodes(sd_bus_message* m) {
  std::vector<NodeStatus> out;
  enter(m, 'a', "{oa{sa{sv}}}");
  while (!at_end(m)) {
    enter(m, 'e', "oa{sa{sv}}");
    const std::string path = read_object_path(m);
    enter(m, 'a', "{sa{sv}}");
    while (!at_end(m)) {
      enter(m, 'e', "sa{sv}");
      if (read_string(m) == kNodeInterface) {
        out.push_back(read_node_status(m));
        out.back().path = path;
      } else {
        expect(sd_bus_message_skip(m, "a{sv}"));
      }
      leave(m);
    }
    leave(m);
    leave(m);
  }
  leave(m);
  return out;
}

namespace {

// (s name, s type, d scale, s unit) of ListObjects and GetPdoMapping.
void read_meaning(sd_bus_message* m, ObjectInfo& o) {
  const char *name = "", *type = "", *unit = "";
  expect_value(sd_bus_message_read(m, "ssds", &name, &type, &o.scale, &unit));
  o.name = name, o.type = type, o.unit = unit;
}

PdoEntryInfo read_pdo_entry(sd_bus_message* m) {
  PdoEntryInfo e;
  enter(m, 'r', "qyyssds");
  expect_value(sd_bus_message_read(m, "qyy", &e.object.index, &e.object.sub, &e.bits));
  read_meaning(m, e.object);
  leave(m);
  return e;
}

PdoInfo read_pdo_info(sd_bus_message* m) {
  PdoInfo p;
  const char* name = "";
  int valid = 0;
  enter(m, 'r', "subya(qyyssds)");
  expect_value(sd_bus_message_read(m, "suby", &name, &p.cob_id, &valid, &p.transmission_type));
  p.name = name, p.valid = valid;
  p.entries = read_array(m, "(qyyssds)", read_pdo_entry);
  leave(m);
  return p;
}

}  // namespace

std::vector<PdoInfo> read_pdo_infos(sd_bus_message* m) { return read_array(m, "(subya(qyyssds))", read_pdo_info); }

std::vector<ObjectInfo> read_object_infos(sd_bus_message* m) {
  return read_array(m, "(qyssds)", [](sd_bus_message* m) {
    ObjectInfo o;
    enter(m, 'r', "qyssds");
    expect_value(sd_bus_message_read(m, "qy", &o.index, &o.sub));
    read_meaning(m, o);
    leave(m);
    return o;
  });
}

std::vector<ObjectInfo> read_count_scaling(sd_bus_message* m) {
  return read_array(m, "(qydds)", [](sd_bus_message* m) {
    ObjectInfo o;
    CountScaling c;
    const char* unit = "";
    expect_value(sd_bus_message_read(m, "(qydds)", &o.index, &o.sub, &c.scale, &c.offset, &unit));
    c.unit = unit;
    o.engineering = c;
    return o;
  });
}

std::map<std::string, std::vector<PdoInfo>> read_fleet_pdo_mappings(sd_bus_message* m) {
  std::map<std::string, std::vector<PdoInfo>> out;
  for (auto& [key, pdos] : read_array(m, "(sa(subya(qyyssds))a(qydds))", [](sd_bus_message* m) {
         enter(m, 'r', "sa(subya(qyyssds))a(qydds)");
         std::string key = read_string(m);
         std::vector<PdoInfo> pdos = read_pdo_infos(m);
         attach_count_scaling(counts_of(pdos), read_count_scaling(m));
         leave(m);
         return std::make_pair(std::move(key), std::move(pdos));
       }))
    out[key] = std::move(pdos);
  return out;
}

std::vector<ObjectInfo*> counts_of(std::vector<PdoInfo>& pdos) {
  std::vector<ObjectInfo*> counts;
  for (PdoInfo& p : pdos)
    for (PdoEntryInfo& e : p.entries)
      if (e.object.unit == kCountsUnit) counts.push_back(&e.object);
  return counts;
}

void attach_count_scaling(std::vector<ObjectInfo*> objects, const std::vector<ObjectInfo>& scaling) {
  for (ObjectInfo* o : objects)
    for (const ObjectInfo& s : scaling)
      if (s.index == o->index && s.sub == o->sub) o->engineering = s.engineering;
}

std::map<std::uint16_t, std::string> read_emcy_codes(sd_bus_message* m) {
  std::map<std::uint16_t, std::string> out;
  for (auto& [code, meaning] : read_array(m, "(qs)", [](sd_bus_message* m) {
         std::uint16_t code = 0;
         const char* meaning = "";
         expect_value(sd_bus_message_read(m, "(qs)", &code, &meaning));
         return std::make_pair(code, std::string(meaning));
       }))
    out[code] = std::move(meaning);
  return out;
}

std::string node_key_of_path(const std::string& path) {
  char *interface = nullptr, *name = nullptr, *index = nullptr;
  int r = sd_bus_path_decode_many(path.c_str(), (std::string(kNodePathPrefix) + "/%/%/%").c_str(), &interface, &name,
                                  &index);
  std::string key = r > 0 ? std::string(interface) + "/" + name + "/" + index : "";
  std::free(interface);
  std::free(name);
  std::free(index);
  return key;
}

Event read_event(sd_bus_message* signal) {
  Event e;
  e.source = source_of(sd_bus_message_get_path(signal));
  e.name = sd_bus_message_get_member(signal);
  if (sd_bus_message_is_signal(signal, kPropertiesInterface, "PropertiesChanged")) {
    read_properties_changed(signal, e);
    return e;
  }
  const SignalSpec* spec = find_signal(e.name);
  if (spec && spec->timed) e.time_us = read_int64(signal);
  for (std::size_t i = 0; !at_end(signal); ++i) {
    bool named = spec && i < spec->args.size();
    std::string name = named ? std::string(spec->args[i].name) : "arg" + std::to_string(i);
    e.fields.push_back({name, read_field(signal), named ? spec->args[i].style : IntegerStyle::kDecimal});
  }
  return e;
}

}  // namespace cansim::ctl
