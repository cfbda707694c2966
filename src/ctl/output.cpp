#include "ctl/output.hpp"

#include <algorithm>
#include <cstdio>

#include "ctl/json.hpp"

namespace cansim::ctl {

namespace {

std::string hex(std::uint64_t n, int digits) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%0*llx", digits, static_cast<unsigned long long>(n));
  return buf;
}

std::string yes_no(bool b) { return b ? "yes" : "no"; }

// A measured quantity for people: six significant digits.
std::string measure(double d) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", d);
  return buf;
}

std::string percent(double fraction) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f%%", fraction * 100.0);
  return buf;
}

// A time span in µs: "0.5 s"; negative is none.
std::string span(std::int64_t us, const char* none) {
  return us < 0 ? none : format_number(double(us) / 1e6) + " s";
}

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
  return measure(r.reported) + " " + r.unit + " reported, " + measure(r.true_value) + " " + r.unit +
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

std::string override_text(const OverrideRow& o) { return o.channel + " " + measure(o.value) + " " + o.unit; }

// Human text of a field value: quoted when it would not read as one word.
std::string field_text(const Field& f) {
  std::string text = format_value(f.value, f.style);
  bool plain = !text.empty() && text.find_first_of(" \"=") == std::string::npos;
  return plain ? text : json_quote(text);
}

void write_reading(JsonWriter& json, std::string_view name, const Reading& r) {
  json.key(name);
  json.begin_object();
  json.member("true", r.true_value);
  json.member("reported", r.reported);
  json.member("unit", r.unit);
  json.member("status", r.status);
  json.end_object();
}

// [{"id", "kind", "active"}]: status's faults and watch's Faults alike.
void write_fault_briefs(JsonWriter& json, const std::vector<FaultBrief>& faults) {
  write_objects(json, faults, [](JsonWriter& json, const FaultBrief& f) {
    json.member("id", f.id);
    json.member("kind", f.kind);
    json.member("active", f.active);
  });
}

void write_status_lists(JsonWriter& json, const NodeStatus& s) {
  json.key("overrides");
  write_objects(json, s.overrides, [](JsonWriter& json, const OverrideRow& o) {
    json.member("channel", o.channel);
    json.member("value", o.value);
    json.member("unit", o.unit);
  });
  json.key("faults");
  write_fault_briefs(json, s.faults);
}

void write_last_emcy(JsonWriter& json, const EmcyRecord& e) {
  json.key("last_emcy");
  if (e.time_us < 0) return json.null();
  json.begin_object();
  json.member("time", double(e.time_us) / 1e6);
  json.member("code", e.code);
  json.member("register", e.error_register);
  json.key("vendor");
  write_json(json, e.vendor);
  json.end_object();
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

std::string format_event(const Event& e) {
  std::string time = e.time_us ? format_seconds(*e.time_us) : "-";
  std::string line = std::string(time.size() < 12 ? 12 - time.size() : 0, ' ') + time + " " + e.source + " " + e.name;
  for (const Field& f : e.fields) line += " " + f.name + "=" + field_text(f);
  return line;
}

void Printer::nodes(const std::vector<NodeRow>& rows) {
  if (json_) {
    return print_objects(out_, rows, [](JsonWriter& json, const NodeRow& r) {
      json.member("path", r.path);
      json.member("key", r.key);
      json.member("name", r.name);
      json.member("interface", r.interface);
      json.member("node_id", r.node_id);
      json.member("profile", r.profile);
      json.member("personality", r.personality);
      json.member("nmt_state", r.nmt_state);
    });
  }
  Table table({"KEY", "NAME", "INTERFACE", "ID", "PROFILE", "PERSONALITY", "NMT"});
  for (const NodeRow& r : rows)
    table.add({r.key, r.name, r.interface, hex(r.node_id, 2), r.profile, r.personality, r.nmt_state});
  table.print(out_);
}

void Printer::status(const NodeStatus& s) {
  if (json_)
    status_json(s);
  else
    status_text(s);
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

void Printer::status_json(const NodeStatus& s) {
  JsonWriter json(out_);
  json.begin_object();
  json.member("path", s.path);
  json.member("key", s.key);
  json.member("name", s.name);
  json.member("index", s.index);
  json.member("profile", s.profile);
  json.member("personality", s.personality);
  json.member("interface", s.interface);
  json.member("node_id", s.node_id);
  json.member("nmt_state", s.nmt_state);
  json.member("powered", s.powered);
  json.member("on_bus", s.on_bus);
  write_reading(json, "pressure", s.pressure);
  write_reading(json, "temperature", s.temperature);
  write_status_lists(json, s);
  json.member("emcy_count", s.emcy_count);
  write_last_emcy(json, s.last_emcy);
  json.member("recording", s.recording);
  json.end_object();
  out_ << '\n';
}

void Printer::fault_id(std::uint32_t id) {
  if (!json_) {
    out_ << id << '\n';
    return;
  }
  JsonWriter json(out_);
  json.begin_object();
  json.member("id", id);
  json.end_object();
  out_ << '\n';
}

void Printer::faults(const std::vector<FaultRow>& rows) {
  if (json_) {
    return print_objects(out_, rows, [](JsonWriter& json, const FaultRow& f) {
      json.member("id", f.id);
      json.member("kind", f.kind);
      json.member("channel", f.channel);
      json.member("active", f.active);
      json.member("start_us", f.start_us);
      json.member("duration_us", f.duration_us);
      json.member("period_us", f.period_us);
      json.member("count", f.count);
    });
  }
  Table table({"ID", "KIND", "CHANNEL", "ACTIVE", "START", "DURATION", "PERIOD", "COUNT"});
  for (const FaultRow& f : rows) {
    table.add({std::to_string(f.id), f.kind, f.channel.empty() ? "-" : f.channel, yes_no(f.active),
               instant(f.start_us), span(f.duration_us, "until cancelled"),
               f.period_us > 0 ? span(f.period_us, "-") : "-", std::to_string(f.count)});
  }
  table.print(out_);
}

void Printer::value(const ObjectAddress& object, const Value& v, const ObjectInfo* meaning) {
  const bool scaled = meaning && meaning->scale != 1.0 && !std::holds_alternative<double>(v);
  const std::string unit = meaning ? meaning->unit : "";
  if (!json_) {
    std::string text = format_value(v);
    if (scaled) {
      text += " = " + engineering_text(v, meaning->scale) + (unit.empty() ? "" : " " + unit);
    } else if (!unit.empty()) {
      text += " " + unit;
    }
    out_ << text << '\n';
    return;
  }
  JsonWriter json(out_);
  json.begin_object();
  json.member("index", object.index);
  json.member("sub", object.sub);
  json.member("type", signature(v));
  json.key("value");
  write_json(json, v);
  json.key("unit");
  if (unit.empty()) json.null(); else json.value(unit);
  json.member("scale", meaning ? meaning->scale : 1.0);
  json.end_object();
  out_ << '\n';
}

void Printer::group(const std::vector<GroupResult>& results) {
  if (!json_) {
    Table table({"NODE", "RESULT"});
    for (const GroupResult& r : results)
      table.add({r.key, r.ok ? (r.fault_id ? std::to_string(*r.fault_id) : "ok") : "refused: " + r.error});
    table.print(out_);
    return;
  }
  print_objects(out_, results, [](JsonWriter& json, const GroupResult& r) {
    json.member("node", r.key);
    json.member("ok", r.ok);
    if (r.fault_id) json.member("id", *r.fault_id);
    if (!r.ok) json.member("error", r.error);
  });
}

void Printer::error(std::ostream& err, bool json, const std::string& what, const std::string& name, int status) {
  if (!json) {
    err << "cansimctl: " << what << '\n';
    return;
  }
  JsonWriter w(err);
  w.begin_object();
  w.member("error", what);
  w.key("name");
  if (name.empty()) w.null(); else w.value(name);
  w.member("exit_status", status);
  w.end_object();
  err << '\n';
}

void Printer::added(const std::vector<NodeRef>& nodes) {
  if (!json_) {
    for (const NodeRef& n : nodes) out_ << n.key << '\n';
    return;
  }
  print_objects(out_, nodes, [](JsonWriter& json, const NodeRef& n) {
    json.member("path", n.path);
    json.member("key", n.key);
  });
}

void Printer::document(std::string_view name, const std::string& text) {
  if (!json_) {
    out_ << text;
    return;
  }
  JsonWriter json(out_);
  json.begin_object();
  json.member(name, std::string_view(text));
  json.end_object();
  out_ << '\n';
}

void Printer::time(std::int64_t us) {
  if (!json_) {
    out_ << format_seconds(us) << " s\n";
    return;
  }
  JsonWriter json(out_);
  json.begin_object();
  json.member("simulated_time_us", us);
  json.member("seconds", double(us) / 1e6);
  json.end_object();
  out_ << '\n';
}

void Printer::stats(const std::vector<BusStats>& rows) {
  if (json_) {
    return print_objects(out_, rows, [](JsonWriter& json, const BusStats& b) {
      json.member("interface", b.name);
      json.member("up", b.up);
      json.member("bit_rate_kbit", b.bit_rate_kbit);
      json.member("frames_in", b.frames_in);
      json.member("frames_out", b.frames_out);
      json.member("frames_dropped", b.frames_dropped);
      json.member("frames_offline", b.frames_offline);
      json.member("offered_load", b.offered_load);
      json.member("measured_load", b.measured_load);
      json.member("bus_model", b.model);
      json.member("controller_state", b.state);
      json.member("offered_load_1s", b.offered_1s);
      json.member("offered_load_10s", b.offered_10s);
      json.member("carried_load_1s", b.carried_1s);
      json.member("carried_load_10s", b.carried_10s);
      json.member("queue_delay_p50_us", b.delay_p50_us);
      json.member("queue_delay_p99_us", b.delay_p99_us);
      json.member("queue_delay_max_us", b.delay_max_us);
      json.member("queued", b.queued);
      json.member("queue_capacity", b.queue_capacity);
      json.member("queue_dropped", b.queue_dropped);
    });
  }
  Table table({"INTERFACE", "UP", "KBIT/S", "IN", "OUT", "DROPPED", "OFFLINE", "OFFERED", "MEASURED"});
  for (const BusStats& b : rows) {
    table.add({b.name, yes_no(b.up), std::to_string(b.bit_rate_kbit), std::to_string(b.frames_in),
               std::to_string(b.frames_out), std::to_string(b.frames_dropped), std::to_string(b.frames_offline),
               percent(b.offered_load), percent(b.measured_load)});
  }
  table.print(out_);
  // The bus model's figures (Fleet1.BusLoad, BusStates): loads over 1 / 10 s,
  // queueing delays over 10 s.
  out_ << '\n';
  Table bus({"INTERFACE", "MODEL", "STATE", "CARRIED 1S", "10S", "OFFERED 1S", "10S", "DELAY P50", "P99", "MAX",
             "QUEUED", "LOST"});
  auto ms = [](std::int64_t us) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f ms", double(us) / 1000.0);
    return std::string(buf);
  };
  for (const BusStats& b : rows)
    bus.add({b.name, b.model, b.state, percent(b.carried_1s), percent(b.carried_10s), percent(b.offered_1s),
             percent(b.offered_10s), ms(b.delay_p50_us), ms(b.delay_p99_us), ms(b.delay_max_us),
             std::to_string(b.queued) + "/" + std::to_string(b.queue_capacity), std::to_string(b.queue_dropped)});
  bus.print(out_);
}

void Printer::event(const Event& e) {
  if (!json_) {
    out_ << format_event(e) << std::endl;
    return;
  }
  JsonWriter json(out_);
  json.begin_object();
  json.key("time");
  if (e.time_us)
    json.value(double(*e.time_us) / 1e6);
  else
    json.null();
  json.member("source", e.source);
  json.member("event", e.name);
  for (const Field& f : e.fields) {
    json.key(f.name);
    if (f.faults) write_fault_briefs(json, *f.faults); else write_json(json, f.value);
  }
  json.end_object();
  out_ << std::endl;
}

}  // namespace cansim::ctl
