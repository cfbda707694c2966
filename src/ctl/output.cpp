#include "ctl/output.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace cansim::ctl {

namespace {

std::string hex(std::uint64_t n, int digits) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%0*llx", digits, static_cast<unsigned long long>(n));
  return buf;
}

std::string yes_no(bool b) { return b ? "yes" : "no"; }

std::string percent(double fraction) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f%%", fraction * 100.0);
  return buf;
}

// A time span in µs: "0.5 s"; negative is none.
std::string span(std::int64_t us, const char* none) { return us < 0 ? none : format_number(double(us) / 1e6) + " s"; }

std::string instant(std::int64_t us) { return us < 0 ? "-" : format_seconds(us); }

template <typename T, typename Format>
std::string joined(const std::vector<T>& items, Format format) {
  if (items.empty()) return "none";
  std::string out;
  for (const T& item : items) out += (out.empty() ? "" : ", ") + format(item);
  return out;
}

std::string reading_text(const Reading& r) {
  if (r.unit.empty()) return "none";
  const std::string counts = std::isnan(r.counts) ? "" : " (" + format_measure(r.counts) + " counts)";
  return format_reading_value(r, r.reported) + counts + " reported, " + format_reading_value(r, r.true_value) +
         " true, status " + hex(r.status, 2);
}

std::string emcy_text(std::uint32_t count, const EmcyRecord& e) {
  std::string out = std::to_string(count) + " sent";
  if (e.time_us < 0) return out;
  return out + ", last at " + format_seconds(e.time_us) + " s: code " + hex(e.code, 4) + ", register " +
         hex(e.error_register, 2) + ", vendor " + format_bytes(e.vendor);
}

std::string fault_brief_text(const FaultBrief& f) {
  return std::to_string(f.id) + " " + f.kind + (f.active ? " (active)" : "");
}

std::string override_text(const OverrideRow& o) { return o.channel + " " + format_measure(o.value) + " " + o.unit; }

// Human text of a field value: quoted when it would not read as one word.
std::string field_text(const Field& f) {
  std::string text = format_value(f.value, f.style);
  bool plain = !text.empty() && text.find_first_of(" \"=") == std::string::npos;
  return plain ? text : Json(text).dump(-1, ' ', false, Json::error_handler_t::replace);
}

}  // namespace

void Table::print(std::ostream& out) const {
  std::vector<std::size_t> widths;
  for (const auto& row : rows_) {
    widths.resize(std::max(widths.size(), row.size()));
    for (std::size_t c = 0; c < row.size(); ++c) widths[c] = std::max(widths[c], row[c].size());
  }
  for (const auto& row : rows_) {
    std::string line;
    for (std::size_t c = 0; c < row.size(); ++c) {
      line += row[c];
      if (c + 1 < row.size()) line += std::string(widths[c] - row[c].size() + 2, ' ');
    }
    line.erase(line.find_last_not_of(' ') + 1);
    out << line << '\n';
  }
}

std::string format_fault_briefs(const std::vector<FaultBrief>& faults) { return joined(faults, fault_brief_text); }

std::string format_reading_value(const Reading& r, double value) {
  return r.unit.empty() ? "-" : format_measure(value) + " " + r.unit;
}

// ---------------------------------------------------------------- JSON

void to_json(Json& j, const NodeRow& r) {
  j = {{"node", r.key},
       {"name", r.name},
       {"interface", r.interface},
       {"node_id", r.node_id},
       {"profile", r.profile},
       {"personality", r.personality},
       {"nmt_state", r.nmt_state},
       {"path", r.path}};
}

void to_json(Json& j, const Reading& r) {
  if (r.unit.empty()) {
    j = nullptr;
    return;
  }
  j = {{"value", json_number(r.reported)},
       {"true_value", json_number(r.true_value)},
       {"unit", r.unit},
       {"status", r.status},
       {"counts", json_number(r.counts)}};
}

void to_json(Json& j, const OverrideRow& o) {
  j = {{"channel", o.channel}, {"value", json_number(o.value)}, {"unit", o.unit}};
}

void to_json(Json& j, const FaultBrief& f) { j = {{"id", f.id}, {"kind", f.kind}, {"active", f.active}}; }

void to_json(Json& j, const FaultRow& f) {
  j = {{"id", f.id},
       {"kind", f.kind},
       {f.plant ? "target" : "channel", json_text_or_null(f.channel)},
       {"active", f.active},
       {"start", json_seconds(f.start_us)},
       {"duration", json_seconds(f.duration_us)},
       {"period", f.period_us > 0 ? json_seconds(f.period_us) : Json(nullptr)},
       {"count", f.count}};
}

void to_json(Json& j, const EmcyRecord& e) {
  if (e.time_us < 0) {
    j = nullptr;
    return;
  }
  j = {{"time", json_seconds(e.time_us)},
       {"code", e.code},
       {"register", e.error_register},
       {"vendor", json_value(e.vendor)}};
}

void to_json(Json& j, const NodeStatus& s) {
  j = {{"node", s.key},
       {"name", s.name},
       {"entry_index", s.index},
       {"interface", s.interface},
       {"node_id", s.node_id},
       {"profile", s.profile},
       {"personality", s.personality},
       {"nmt_state", s.nmt_state},
       {"powered", s.powered},
       {"on_bus", s.on_bus},
       {"pressure", s.pressure},
       {"temperature", s.temperature},
       {"overrides", s.overrides},
       {"faults", s.faults},
       {"emcy_count", s.emcy_count},
       {"last_emcy", s.last_emcy},
       {"recording", json_text_or_null(s.recording)},
       {"path", s.path}};
}

void to_json(Json& j, const GroupResult& r) {
  j = {{"node", r.key}, {"ok", r.ok}};
  if (r.fault_id) j["id"] = *r.fault_id;
  if (!r.ok) j["error"] = r.error;
}

void to_json(Json& j, const NodeRef& n) { j = {{"node", n.key}, {"path", n.path}}; }

void to_json(Json& j, const BusStats& b) {
  j = {{"interface", b.name},
       {"up", b.up},
       {"bit_rate_kbit", b.bit_rate_kbit},
       {"frames_in", b.frames_in},
       {"frames_out", b.frames_out},
       {"frames_dropped", b.frames_dropped},
       {"frames_offline", b.frames_offline},
       {"offered_load", json_number(b.offered_load)},
       {"measured_load", json_number(b.measured_load)},
       {"bus_model", b.model},
       {"controller_state", b.state},
       {"offered_load_1s", json_number(b.offered_1s)},
       {"offered_load_10s", json_number(b.offered_10s)},
       {"carried_load_1s", json_number(b.carried_1s)},
       {"carried_load_10s", json_number(b.carried_10s)},
       {"queue_delay_p50_us", b.delay_p50_us},
       {"queue_delay_p99_us", b.delay_p99_us},
       {"queue_delay_max_us", b.delay_max_us},
       {"slip_p99_us", b.slip_p99_us},
       {"slip_max_us", b.slip_max_us},
       {"queued", b.queued},
       {"queue_capacity", b.queue_capacity},
       {"queue_dropped", b.queue_dropped},
       {"transport", b.transport}};
  if (b.transport == "socketcand") {
    j["listen_host"] = b.listen_host;
    j["listen_port"] = b.listen_port;
    j["clients"] = b.clients;
  }
}

// {"time", "node", "kind": the signal, "fields": [{"name", "value"}]}.
void to_json(Json& j, const Event& e) {
  Json fields = Json::array();
  for (const Field& f : e.fields)
    fields.push_back({{"name", f.name}, {"value", f.faults ? Json(*f.faults) : json_value(f.value)}});
  j = {{"time", e.time_us ? json_seconds(*e.time_us) : Json(nullptr)},
       {"node", e.source == "fleet" || e.source.starts_with('/') ? Json(nullptr) : Json(e.source)},
       {"kind", e.name},
       {"fields", std::move(fields)}};
}

std::string format_event(const Event& e) {
  std::string time = e.time_us ? format_seconds(*e.time_us) : "-";
  std::string line = std::string(time.size() < 12 ? 12 - time.size() : 0, ' ') + time + " " + e.source + " " + e.name;
  for (const Field& f : e.fields) line += " " + f.name + "=" + field_text(f);
  return line;
}

void Printer::nodes(const std::vector<NodeRow>& rows) {
  if (json_) return print_json(out_, rows);
  Table table({"KEY", "NAME", "INTERFACE", "ID", "PROFILE", "PERSONALITY", "NMT"});
  for (const NodeRow& r : rows)
    table.add({r.key, r.name, r.interface, hex(r.node_id, 2), r.profile, r.personality, r.nmt_state});
  table.print(out_);
}

void Printer::status(const NodeStatus& s) {
  if (json_) print_json(out_, s);
  else status_text(s);
}

void Printer::status_text(const NodeStatus& s) {
  std::string power = s.powered ? (s.on_bus ? "on, on the bus" : "on, off the bus") : "off";
  Table table({s.key, ""});
  table.add({"  name", s.name + " (index " + std::to_string(s.index) + ")"});
  table.add({"  profile", s.profile});
  table.add({"  personality", s.personality});
  table.add({"  interface", s.interface});
  table.add({"  node-ID", hex(s.node_id, 2) + " (" + std::to_string(s.node_id) + ")"});
  table.add({"  NMT state", s.nmt_state});
  table.add({"  power", power});
  table.add({"  pressure", reading_text(s.pressure)});
  table.add({"  temperature", reading_text(s.temperature)});
  table.add({"  overrides", joined(s.overrides, override_text)});
  table.add({"  faults", format_fault_briefs(s.faults)});
  table.add({"  EMCY", emcy_text(s.emcy_count, s.last_emcy)});
  table.add({"  recording", s.recording.empty() ? "none" : s.recording});
  table.print(out_);
}

void Printer::faults(const std::vector<FaultRow>& rows, const char* column) {
  if (json_) return print_json(out_, rows);
  Table table({"ID", "KIND", column, "ACTIVE", "START", "DURATION", "PERIOD", "COUNT"});
  for (const FaultRow& f : rows) {
    table.add({std::to_string(f.id), f.kind, f.channel.empty() ? "-" : f.channel, yes_no(f.active), instant(f.start_us),
               span(f.duration_us, "until cancelled"), f.period_us > 0 ? span(f.period_us, "-") : "-",
               std::to_string(f.count)});
  }
  table.print(out_);
}

void Printer::value(const std::string& node, const ObjectAddress& object, const Value& v, const ObjectInfo* meaning) {
  const ObjectInfo none{object.index, object.sub, "", "", 1.0, ""};
  const ObjectInfo& o = meaning ? *meaning : none;
  const DecodedField field = object_field(o, v);
  if (json_) {
    print_json(out_, {{"node", node},
                      {"index", object.index},
                      {"sub", object.sub},
                      {"name", json_text_or_null(o.name)},
                      {"type", json_text_or_null(o.type)},
                      {"value", field.value ? json_value(*field.value) : Json(nullptr)},
                      {"unit", json_text_or_null(field.unit)},
                      {"raw", json_value(v)},
                      {"counts", field.counts ? json_number(*field.counts) : Json(nullptr)}});
    return;
  }
  const std::string unit = field.unit.empty() ? "" : " " + field.unit;
  const bool derived = field.value && *field.value != v;
  if (field.counts && field.unit != kCountsUnit)
    out_ << format_measure(*field.counts) << " counts = " << format_field_value(field) << unit << '\n';
  else if (derived) out_ << format_value(v) << " = " << format_field_value(field) << unit << '\n';
  else if (std::holds_alternative<double>(v)) out_ << format_measure(std::get<double>(v)) << unit << '\n';
  else out_ << format_value(v) << unit << '\n';
}

void Printer::acted(const GroupResult& result) {
  if (json_) return print_json(out_, result);
  if (result.fault_id) out_ << *result.fault_id << '\n';
}

void Printer::group(const std::vector<GroupResult>& results) {
  if (!json_) {
    Table table({"NODE", "RESULT"});
    for (const GroupResult& r : results)
      table.add({r.key, r.ok ? (r.fault_id ? std::to_string(*r.fault_id) : "ok") : "refused: " + r.error});
    table.print(out_);
    return;
  }
  print_json(out_, results);
}

void Printer::error(std::ostream& err, bool json, const std::string& what, const std::string& name, int status) {
  if (!json) {
    err << "cansimctl: " << what << '\n';
    return;
  }
  print_json(err, {{"error", what}, {"name", json_text_or_null(name)}, {"exit_status", status}});
}

void Printer::added(const std::vector<NodeRef>& nodes) {
  if (!json_) {
    for (const NodeRef& n : nodes) out_ << n.key << '\n';
    return;
  }
  print_json(out_, nodes);
}

void Printer::done() {
  if (json_) print_json(out_, {{"ok", true}});
}

void Printer::document(std::string_view name, const std::string& text) {
  if (!json_) {
    out_ << text;
    return;
  }
  print_json(out_, {{std::string(name), text}});
}

void Printer::time(std::int64_t us) {
  if (!json_) {
    out_ << format_seconds(us) << " s\n";
    return;
  }
  print_json(out_, {{"time", json_seconds(us)}});
}

void Printer::stats(const std::vector<BusStats>& rows) {
  if (json_) return print_json(out_, rows);
  Table table({"INTERFACE", "UP", "KBIT/S", "IN", "OUT", "DROPPED", "OFFLINE"});
  for (const BusStats& b : rows) {
    table.add({b.name, yes_no(b.up), std::to_string(b.bit_rate_kbit), std::to_string(b.frames_in),
               std::to_string(b.frames_out), std::to_string(b.frames_dropped), std::to_string(b.frames_offline)});
  }
  table.print(out_);
  // The bus's one set of load figures (Fleet1.BusLoad, BusStates): carried
  // (at most 100 %) and offered over 1 / 10 s, queueing delays and the
  // slip over 10 s.
  out_ << '\n';
  Table bus({"INTERFACE", "MODEL", "STATE", "CARRIED 1S", "10S", "OFFERED 1S", "10S", "DELAY P50", "P99", "MAX",
             "SLIP P99", "MAX", "QUEUED", "LOST"});
  auto ms = [](std::int64_t us) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f ms", double(us) / 1000.0);
    return std::string(buf);
  };
  for (const BusStats& b : rows)
    bus.add({b.name, b.model, b.state, percent(b.carried_1s), percent(b.carried_10s), percent(b.offered_1s),
             percent(b.offered_10s), ms(b.delay_p50_us), ms(b.delay_p99_us), ms(b.delay_max_us), ms(b.slip_p99_us),
             ms(b.slip_max_us), std::to_string(b.queued) + "/" + std::to_string(b.queue_capacity),
             std::to_string(b.queue_dropped)});
  bus.print(out_);
  // Buses cansimd serves over TCP (Fleet1.SocketcandBuses): where clients connect.
  Table served({"INTERFACE", "TRANSPORT", "LISTEN", "CLIENTS"});
  bool any = false;
  for (const BusStats& b : rows) {
    if (b.transport != "socketcand") continue;
    any = true;
    const bool v6 = b.listen_host.find(':') != std::string::npos;
    const std::string host = v6 ? "[" + b.listen_host + "]" : b.listen_host;
    served.add({b.name, b.transport, b.listen_port ? host + ":" + std::to_string(b.listen_port) : "(not listening)",
                std::to_string(b.clients)});
  }
  if (!any) return;
  out_ << '\n';
  served.print(out_);
}

void Printer::event(const Event& e) {
  if (json_) print_json(out_, e);
  else out_ << format_event(e) << '\n';
  out_.flush();
}

}  // namespace cansim::ctl
