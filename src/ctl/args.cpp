#include <cctype>
#include "ctl/args.hpp"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>

namespace cansim::ctl {

namespace {

// ---------------------------------------------------------------- words

// A verb's arguments: its positional words and the verb options given.
struct Words {
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;  // name -> value ("" for a flag)

  const std::string& operator[](std::size_t i) const { return positional[i]; }
  std::size_t size() const { return positional.size(); }
  bool has(const std::string& option) const { return options.count(option) != 0; }
  const std::string* option(const std::string& name) const {
    auto it = options.find(name);
    return it == options.end() ? nullptr : &it->second;
  }
};

// ---------------------------------------------------------------- argument helpers

Arg text(std::string s) { return Value(std::move(s)); }
Arg real(double d) { return Value(d); }

Call node_call(std::string method, std::vector<Arg> args = {}) {
  return {Target::kNode, kNodeInterface, std::move(method), std::move(args)};
}

Call fleet_call(std::string method, std::vector<Arg> args = {}) {
  return {Target::kFleet, kFleetInterface, std::move(method), std::move(args)};
}

Request on_node(const Words& w, Call call, Output output = Output::kNothing) {
  Request r;
  r.node = w[0];
  r.call = std::move(call);
  r.output = output;
  return r;
}

Request on_fleet(Call call, Output output = Output::kNothing) {
  Request r;
  r.call = std::move(call);
  r.output = output;
  return r;
}

std::string quoted(const std::string& s) { return "'" + s + "'"; }

std::string channel(const std::string& word) {
  if (word != "pressure" && word != "temperature")
    throw UsageError("channel must be pressure or temperature, got " + quoted(word));
  return word;
}

double number(const std::string& word) {
  auto v = parse_real(word);
  if (!v) throw UsageError("expected a number, got " + quoted(word));
  return *v;
}

double duration_seconds(const std::string& word) {
  auto v = parse_duration_seconds(word);
  if (!v) throw UsageError("expected a duration like '500ms' or '2 s', got " + quoted(word));
  return *v;
}

std::string duration_text(const std::string& word) {
  auto v = normalise_duration(word);
  if (!v) throw UsageError("expected a time like '500ms' or '2 s', got " + quoted(word));
  return *v;
}

ObjectAddress object_address(const std::string& word) {
  auto a = parse_object_address(word);
  if (!a) throw UsageError("expected INDEX[:SUB] like 0x6130:1, got " + quoted(word));
  return *a;
}

std::uint64_t unsigned_word(const std::string& word, std::uint64_t max, const char* what) {
  auto v = parse_unsigned(word);
  if (!v || *v > max) throw UsageError(std::string("expected ") + what + ", got " + quoted(word));
  return *v;
}

// ---------------------------------------------------------------- verbs

Request build_help(const Words&) { return {}; }  // parse_command_line answers it

Request build_list(const Words&) { return on_fleet(fleet_call("ListNodes"), Output::kNodes); }

Request build_status(const Words& w) {
  Call get_all{Target::kNode, kPropertiesInterface, "GetAll", {text(kNodeInterface)}};
  return on_node(w, get_all, Output::kStatus);
}

Request build_set(const Words& w) {
  std::vector<Arg> args{text(channel(w[1])), real(number(w[2])), text(w[3])};
  const std::string* ramp = w.option("--ramp");
  if (!ramp) return on_node(w, node_call("Step", args));
  args.push_back(real(duration_seconds(*ramp)));
  return on_node(w, node_call("Ramp", args));
}

Request build_hold(const Words& w) { return on_node(w, node_call("Hold", {text(channel(w[1]))})); }

Request build_model(const Words& w) { return on_node(w, node_call("SetModel", {text(channel(w[1])), text(w[2])})); }

Request build_restore_model(const Words& w) { return on_node(w, node_call("RestoreModel", {text(channel(w[1]))})); }

Request build_override(const Words& w) {
  bool off = w.has("--off");
  if (w.size() != (off ? 2u : 4u)) throw UsageError("override takes NODE CHANNEL VALUE UNIT, or NODE CHANNEL --off");
  if (off) return on_node(w, node_call("ClearOverride", {text(channel(w[1]))}));
  return on_node(w, node_call("Override", {text(channel(w[1])), real(number(w[2])), text(w[3])}));
}

StringMap fault_parameters(const Words& w) {
  StringMap params;
  for (std::size_t i = 2; i < w.size(); ++i) {
    std::size_t eq = w[i].find('=');
    if (eq == 0 || eq == std::string::npos) throw UsageError("expected KEY=VALUE, got " + quoted(w[i]));
    params[w[i].substr(0, eq)] = w[i].substr(eq + 1);
  }
  auto set_time = [&params](const std::string& key, const std::string* option, const char* name) {
    if (!option) return;
    if (params.count(key)) throw UsageError(std::string(name) + " and " + key + "= both given");
    params[key] = duration_text(*option);
  };
  set_time("duration", w.option("--for"), "--for");
  set_time("at", w.option("--at"), "--at");
  return params;
}

Request build_fault(const Words& w) {
  return on_node(w, node_call("ArmFault", {text(w[1]), fault_parameters(w)}), Output::kFaultId);
}

Request build_faults(const Words& w) { return on_node(w, node_call("ListFaults"), Output::kFaults); }

Request build_cancel(const Words& w) {
  auto id = unsigned_word(w[1], std::numeric_limits<std::uint32_t>::max(), "a fault id");
  return on_node(w, node_call("CancelFault", {Value(std::uint32_t(id))}));
}

Request build_power_cycle(const Words& w) {
  const std::string* off = w.option("--off");
  return on_node(w, node_call("PowerCycle", {real(off ? duration_seconds(*off) : 0.0)}));
}

Request build_nmt(const Words& w) {
  static const char* const kCommands[] = {"start", "stop", "preop", "reset", "reset-comm"};
  for (const char* c : kCommands) {
    if (w[1] == c) return on_node(w, node_call("Nmt", {text(w[1])}));
  }
  throw UsageError("NMT command must be start, stop, preop, reset or reset-comm, got " + quoted(w[1]));
}

std::vector<Arg> address_args(const ObjectAddress& a) { return {Value(a.index), Value(a.sub)}; }

Request build_read(const Words& w) {
  ObjectAddress a = object_address(w[1]);
  Request r = on_node(w, node_call("Read", address_args(a)), Output::kValue);
  r.object = a;
  return r;
}

Request build_write(const Words& w) {
  const std::string* type = w.option("--type");
  if (type && !is_write_type(*type))
    throw UsageError("--type must be one of " + std::string(write_type_names()) + ", got " + quoted(*type));
  auto value = typed_value(w[2], type ? *type : "");
  if (!value) throw UsageError("cannot write " + quoted(w[2]) + (type ? " as " + *type : std::string()));
  std::vector<Arg> args = address_args(object_address(w[1]));
  args.push_back(Variant{*value});
  return on_node(w, node_call("Write", args));
}

Request build_record(const Words& w) {
  bool stop = w.has("--stop");
  if (w.size() != (stop ? 1u : 2u)) throw UsageError("record takes NODE PATH, or NODE --stop");
  if (stop) return on_node(w, node_call("StopRecording"));
  // The daemon resolves relative paths from its own working directory.
  std::string path = std::filesystem::absolute(w[1]).lexically_normal().string();
  return on_node(w, node_call("StartRecording", {text(path)}));
}

// Store and Restore: the 0x1010 / 0x1011 sub-index, 1 (all parameters) by
// default; 1..127 as the daemon takes them (CiA 301: 128..254 reserved).
Request build_store_call(const Words& w, const char* method) {
  constexpr const char* kWhat = "a sub-index 1..127 (1: all parameters)";
  auto sub = w.size() > 1 ? unsigned_word(w[1], 127, kWhat) : 1;
  if (sub == 0) throw UsageError(std::string("expected ") + kWhat + ", got " + quoted(w[1]));
  return on_node(w, node_call(method, {Value(std::uint8_t(sub))}));
}

Request build_store(const Words& w) { return build_store_call(w, "Store"); }
Request build_restore(const Words& w) { return build_store_call(w, "Restore"); }

Request build_watch(const Words& w) {
  Request r = on_fleet(fleet_call("Subscribe"), Output::kWatch);
  if (w.size() > 0) r.node = w[0];
  return r;
}

Request build_monitor(const Words& w) {
  Request r = on_fleet(fleet_call("Subscribe"), Output::kMonitor);
  r.interfaces = w.positional;
  if (const std::string* node = w.option("--node")) r.node = *node;
  return r;
}

Request build_top(const Words& w) {
  Request r = on_fleet(fleet_call("Subscribe"), Output::kTop);
  if (w.size() > 0) r.pattern = w[0];
  r.once = w.has("--once");
  return r;
}

Request build_add(const Words& w) {
  Request r = on_fleet(fleet_call("AddNodes"), Output::kAdded);
  r.file = w[0];
  return r;
}

Request build_remove(const Words& w) { return on_fleet(fleet_call("RemoveNode", {text(w[0])})); }

Request build_reload(const Words&) { return on_fleet(fleet_call("Reload")); }

Request build_time(const Words&) {
  Call get{Target::kFleet, kPropertiesInterface, "Get", {text(kFleetInterface), text("SimulatedTime")}};
  return on_fleet(get, Output::kTime);
}

Request build_dcf(const Words& w) {
  Request r = on_node(w, node_call("GetDcf"), Output::kDcf);
  if (const std::string* output = w.option("--output")) r.file = *output;
  return r;
}

Request build_stats(const Words&) { return on_fleet(fleet_call("GetBusStatistics"), Output::kStats); }

struct OptionSpec {
  std::string_view name;
  bool takes_value;
};

constexpr std::size_t kAny = std::numeric_limits<std::size_t>::max();

struct VerbSpec {
  std::string_view name;
  std::string_view synopsis;  // the arguments, for the usage
  std::string_view description;
  std::size_t min_words;
  std::size_t max_words;
  std::vector<OptionSpec> options;
  Request (*build)(const Words&);
  bool groups = false;  // NODE may name several nodes (a glob, an ID range, a count: group)
};

constexpr bool kGroups = true;

const std::vector<VerbSpec>& verbs() {
  static const std::vector<VerbSpec> kVerbs = {
      {"help", "[COMMAND]", "this usage, or a command's help", 0, 1, {}, build_help},
      {"list", "", "list the nodes", 0, 0, {}, build_list},
      {"status", "NODE", "show a node's properties", 1, 1, {}, build_status},
      {"set", "NODE CHANNEL VALUE UNIT [--ramp DURATION]",
       "set the true value: at once, or ramping there over DURATION", 4, 4, {{"--ramp", true}}, build_set, kGroups},
      {"hold", "NODE CHANNEL", "keep the true value at its present level", 2, 2, {}, build_hold},
      {"model", "NODE CHANNEL YAML", "replace the process model (YAML as in the profile's physics:)", 3, 3, {},
       build_model},
      {"restore-model", "NODE CHANNEL", "back to the profile's process model", 2, 2, {}, build_restore_model},
      {"override", "NODE CHANNEL VALUE UNIT | --off",
       "report VALUE whatever the sensor measures; --off: stop doing so", 2, 4, {{"--off", false}}, build_override, kGroups},
      {"fault", "NODE KIND [--for DURATION] [--at TIME] [KEY=VALUE...]",
       "arm a fault (kind and keys as in a profile's faults:), print its id", 2, kAny,
       {{"--for", true}, {"--at", true}}, build_fault, kGroups},
      {"faults", "NODE", "list the armed faults", 1, 1, {}, build_faults},
      {"cancel", "NODE ID", "end fault ID", 2, 2, {}, build_cancel, kGroups},
      {"power-cycle", "NODE [--off DURATION]", "power off, on again after DURATION (default 0: reboot)", 1, 1,
       {{"--off", true}}, build_power_cycle, kGroups},
      {"nmt", "NODE start|stop|preop|reset|reset-comm", "a local NMT transition", 2, 2, {}, build_nmt, kGroups},
      {"read", "NODE INDEX[:SUB]", "read an object (0x6130:1, 1017h, 4119; SUB default 0)", 2, 2, {}, build_read},
      {"write", "NODE INDEX[:SUB] VALUE [--type TYPE]",
       "write an object; VALUE typed by its look unless TYPE is given", 3, 3, {{"--type", true}}, build_write},
      {"record", "NODE PATH | --stop", "record true and reported values to a CSV file", 1, 2, {{"--stop", false}},
       build_record},
      {"store", "NODE [SUB]", "save parameters as a write of 0x1010:SUB (default 1: all)", 1, 2, {}, build_store},
      {"restore", "NODE [SUB]", "restore defaults as a write of 0x1011:SUB (default 1: all)", 1, 2, {},
       build_restore},
      {"dcf", "NODE [--output FILE]", "the node's CiA 306 DCF (current values), printed or written to FILE", 1, 1,
       {{"--output", true}}, build_dcf},
      {"watch", "[NODE]", "print events and property changes until Ctrl-C", 0, 1, {}, build_watch},
      {"monitor", "[IFACE...] [--node NODE]",
       "print every frame decoded (PDO values in engineering units, SDO, NMT, EMCY...) until Ctrl-C", 0, kAny,
       {{"--node", true}}, build_monitor},
      {"top", "[GLOB] [--once]",
       "the fleet at a glance, refreshed twice a second (GLOB: keys or names like 'generic/*'); --once: one table",
       0, 1, {{"--once", false}}, build_top},
      {"add", "FILE.yaml", "add the nodes of a fleet YAML fragment, print them", 1, 1, {}, build_add},
      {"remove", "NODE", "remove a node", 1, 1, {}, build_remove},
      {"reload", "", "re-read the configuration file (as SIGHUP)", 0, 0, {}, build_reload},
      {"time", "", "print the simulated time", 0, 0, {}, build_time},
      {"stats", "", "per-interface bus statistics", 0, 0, {}, build_stats},
  };
  return kVerbs;
}

const VerbSpec* lookup_verb(std::string_view name) {
  for (const VerbSpec& v : verbs()) {
    if (v.name == name) return &v;
  }
  return nullptr;
}

const VerbSpec& find_verb(const std::string& name) {
  if (const VerbSpec* v = lookup_verb(name)) return *v;
  throw UsageError("unknown command " + quoted(name) + " (cansimctl help lists them)");
}

const OptionSpec* find_option(const VerbSpec& verb, const std::string& name) {
  for (const OptionSpec& o : verb.options) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

// ---------------------------------------------------------------- scanning

struct OptionWord {
  std::string name;
  std::optional<std::string> inline_value;  // --name=value
};

// "-5" and "-.5" are negative numbers (a temperature), not options.
// "-5", "-.5" are numbers and "- constant: 4 bar" is a YAML list: not options.
bool is_option(const std::string& arg) {
  if (arg.size() < 2 || arg[0] != '-') return false;
  return !(arg[1] == '.' || (arg[1] >= '0' && arg[1] <= '9') || std::isspace(static_cast<unsigned char>(arg[1])));
}

OptionWord split_option(const std::string& arg) {
  std::size_t eq = arg.find('=');
  if (arg.rfind("--", 0) != 0 || eq == std::string::npos) return {arg, std::nullopt};
  return {arg.substr(0, eq), arg.substr(eq + 1)};
}

class Scanner {
 public:
  explicit Scanner(const std::vector<std::string>& args) : args_(args) {}

  bool more() const { return next_ < args_.size(); }
  const std::string& take() { return args_[next_++]; }

  std::string value(const OptionWord& o) {
    if (o.inline_value) return *o.inline_value;
    if (!more()) throw UsageError("option " + o.name + " needs a value");
    return take();
  }

  static void no_value(const OptionWord& o) {
    if (o.inline_value) throw UsageError("option " + o.name + " takes no value");
  }

 private:
  const std::vector<std::string>& args_;
  std::size_t next_ = 0;
};

void select_bus(GlobalOptions& g, BusKind kind) {
  if (g.bus != BusKind::kDefault) throw UsageError("--socket, --system and --user exclude each other");
  g.bus = kind;
}

double timeout_seconds(const std::string& word) {
  auto v = parse_real(word);
  if (!v || !(*v > 0) || !std::isfinite(*v)) throw UsageError("--timeout needs a positive number of seconds");
  return *v;
}

// Applies a global option; false when o is none.
bool take_global(const OptionWord& o, Scanner& s, GlobalOptions& g) {
  if (o.name == "--socket") {
    select_bus(g, BusKind::kSocket);
    g.socket = s.value(o);
    if (g.socket.empty()) throw UsageError("--socket needs a path");
    return true;
  }
  if (o.name == "--timeout") {
    g.timeout_s = timeout_seconds(s.value(o));
    return true;
  }
  struct Flag {
    std::string_view name;
    void (*apply)(GlobalOptions&);
  };
  static constexpr Flag kFlags[] = {
      {"--system", [](GlobalOptions& g) { select_bus(g, BusKind::kSystem); }},
      {"--user", [](GlobalOptions& g) { select_bus(g, BusKind::kUser); }},
      {"--json", [](GlobalOptions& g) { g.json = true; }},
      {"--help", [](GlobalOptions& g) { g.help = true; }},
      {"-h", [](GlobalOptions& g) { g.help = true; }},
      {"--version", [](GlobalOptions& g) { g.version = true; }},
  };
  for (const Flag& f : kFlags) {
    if (f.name != o.name) continue;
    Scanner::no_value(o);
    f.apply(g);
    return true;
  }
  return false;
}

void take_verb_option(const OptionWord& o, Scanner& s, const VerbSpec& verb, Words& words) {
  const OptionSpec* spec = find_option(verb, o.name);
  if (!spec) throw UsageError("unknown option " + o.name + " for " + std::string(verb.name));
  if (words.has(o.name)) throw UsageError("option " + o.name + " given twice");
  if (!spec->takes_value) Scanner::no_value(o);
  words.options[o.name] = spec->takes_value ? s.value(o) : "";
}

std::string verb_synopsis(const VerbSpec& v) {
  return v.synopsis.empty() ? std::string(v.name) : std::string(v.name) + " " + std::string(v.synopsis);
}

// ---------------------------------------------------------------- help

bool mentions(const VerbSpec& v, std::string_view word) { return v.synopsis.find(word) != std::string_view::npos; }

// What an argument of a verb's synopsis means, printed by `VERB --help`.
struct ArgumentHelp {
  bool (*applies)(const VerbSpec&);
  const char* text;
};

const std::vector<ArgumentHelp>& argument_help() {
  static const std::vector<ArgumentHelp> kHelp = {
      {[](const VerbSpec& v) { return mentions(v, "NODE") && !v.groups; },
       "NODE: a node's name (dps, or generic/1 in a count: group), its fleet key\n"
       "  (vcan0/dps/0) or IFACE/ID (vcan0/0x10).\n"},
      {[](const VerbSpec& v) { return v.groups; },
       "NODE: a node's name (dps, or generic/1 in a count: group), its fleet key\n"
       "  (vcan0/dps/0) or IFACE/ID (vcan0/0x10); or several nodes, each acted on and\n"
       "  reported on its own line (exit status 1 when one refused): a glob of keys or\n"
       "  names ('generic/*', 'vcan1/*'), an ID range (vcan0/0x10-0x13) or the name of\n"
       "  a count: group (generic).\n"},
      {[](const VerbSpec& v) { return mentions(v, "CHANNEL"); }, "CHANNEL: pressure or temperature.\n"},
      {[](const VerbSpec& v) { return mentions(v, "UNIT"); },
       "UNIT: bar, mbar, psi, Pa, kPa, MPa (pressure); degC, degF, K (temperature).\n"},
      {[](const VerbSpec& v) { return mentions(v, "DURATION") || mentions(v, "TIME"); },
       "DURATION, TIME: a number and s, ms, us, min or h (\"500ms\", \"2 s\"), seconds if bare;\n"
       "  TIME is simulated time since the daemon's start.\n"},
      {[](const VerbSpec& v) { return mentions(v, "KIND"); },
       "KIND: open, short, stuck, drift, spikes, noise_burst, over_temperature,\n"
       "  eeprom_error, silent, power_cycle, bus_off, heartbeat_stop, slow_sdo,\n"
       "  sdo_block_drop; KEY=VALUE as in a profile's faults: (value=2 bar,\n"
       "  drift=0.5 bar, channel=temperature, count=3, period=1 s, ...).\n"},
      {[](const VerbSpec& v) { return mentions(v, "INDEX"); },
       "INDEX[:SUB]: 0x6130:1, 1017h, 4119 (SUB 0 when omitted). read prints a process\n"
       "  value with its unit (3.5 bar; an integer view as 350 (0x15e) = 3.50 bar).\n"},
      {[](const VerbSpec& v) { return v.name == "write"; },
       "VALUE: integers, 0x hex, decimals, \"quoted\" or other text, typed by its look;\n"
       "  --type bool u8 u16 u32 u64 i8 i16 i32 i64 f32 f64 str bytes (bytes: 01:02:ff).\n"},
      {[](const VerbSpec& v) { return mentions(v, "GLOB"); },
       "GLOB: keys or names: 'generic/*', 'vcan1/*', 'dps'.\n"},
      {[](const VerbSpec& v) { return mentions(v, "IFACE"); },
       "IFACE: CAN interfaces to listen on (default: every interface of the fleet).\n"},
  };
  return kHelp;
}

std::string arguments_text(std::size_t n) { return n == 1 ? "1 argument" : std::to_string(n) + " arguments"; }

std::string count_error(const VerbSpec& v, std::size_t given) {
  const std::string expected = v.min_words == v.max_words ? std::to_string(v.min_words)
                               : v.max_words == kAny     ? "at least " + std::to_string(v.min_words)
                                                         : std::to_string(v.min_words) + " to " + std::to_string(v.max_words);
  return std::string(v.name) + ": " + arguments_text(given) + " given, expected " + expected;
}

// The line after the global options: the verb's words, checked and built.
void parse_verb_line(Scanner& s, CommandLine& line, const VerbSpec*& verb) {
  Words words;
  bool options_ended = false;
  while (s.more()) {
    const std::string& arg = s.take();
    if (!options_ended && arg == "--") {
      options_ended = true;
    } else if (options_ended || !is_option(arg)) {
      if (verb)
        words.positional.push_back(arg);
      else
        verb = &find_verb(arg);
    } else if (OptionWord o = split_option(arg); take_global(o, s, line.global)) {
      if (line.global.version) return;
    } else if (verb) {
      take_verb_option(o, s, *verb, words);
    } else {
      throw UsageError("unknown option " + o.name);
    }
  }
  if (line.global.help) {
    if (verb) line.help_verb = verb->name;
    return;
  }
  if (!verb) throw UsageError("no command given");
  if (verb->name == "help") {
    line.global.help = true;
    if (words.size() == 1) line.help_verb = find_verb(words[0]).name;
    if (words.size() > 1) throw UsageError(count_error(*verb, words.size()), "help");
    return;
  }
  if (words.size() < verb->min_words || words.size() > verb->max_words)
    throw UsageError(count_error(*verb, words.size()));
  line.request = verb->build(words);
  line.request.group = verb->groups;
}

}  // namespace

CommandLine parse_command_line(const std::vector<std::string>& args) {
  CommandLine line;
  const VerbSpec* verb = nullptr;
  Scanner s(args);
  try {
    parse_verb_line(s, line, verb);
  } catch (const UsageError& e) {
    if (e.verb.empty() && verb) throw UsageError(e.what(), std::string(verb->name));
    throw;
  }
  return line;
}

std::vector<std::string> verb_names() {
  std::vector<std::string> out;
  for (const VerbSpec& v : verbs()) out.emplace_back(v.name);
  return out;
}

std::string verb_usage(const std::string& verb) {
  const VerbSpec* v = lookup_verb(verb);
  if (!v) return usage_text();
  return "usage: cansimctl " + verb_synopsis(*v) + "\nTry 'cansimctl " + verb + " --help' for more.\n";
}

std::string verb_help(const std::string& verb) {
  const VerbSpec* v = lookup_verb(verb);
  if (!v) return usage_text();
  std::string out = "usage: cansimctl " + verb_synopsis(*v) + "\n\n" + std::string(v->description) + ".\n";
  std::string glossary;
  for (const ArgumentHelp& a : argument_help()) {
    if (!a.applies(*v)) continue;
    glossary += a.text;
  }
  if (!glossary.empty()) out += "\n" + glossary;
  return out + "\nGlobal options (--socket, --system, --user, --json, --timeout): cansimctl --help.\n";
}

std::string usage_text() {
  std::string out =
      "usage: cansimctl [OPTIONS] COMMAND [ARGUMENTS]\n"
      "\n"
      "Controls a running cansimd through its D-Bus control API.\n"
      "cansimctl COMMAND --help (or cansimctl help COMMAND) explains one command.\n"
      "\n"
      "Commands:\n";
  constexpr std::size_t kColumn = 44;
  for (const VerbSpec& v : verbs()) {
    std::string synopsis = "  " + verb_synopsis(v);
    out += synopsis.size() < kColumn ? synopsis + std::string(kColumn - synopsis.size(), ' ')
                                     : synopsis + "\n" + std::string(kColumn, ' ');
    out += std::string(v.description) + "\n";
  }
  out += "\n"
         "NODE: a node's name (dps, or generic/1 in a count: group), its fleet key\n"
         "  (vcan0/dps/0) or IFACE/ID (vcan0/0x10); set, override, fault, cancel,\n"
         "  power-cycle and nmt also take several: a glob ('generic/*'), an ID range\n"
         "  (vcan0/0x10-0x13) or a count: group's name (generic).\n"
         "CHANNEL: pressure or temperature. UNIT: bar, mbar, psi, Pa, kPa, MPa, degC, degF, K.\n"
         "DURATION, TIME: a number and s, ms, us, min or h (\"500ms\", \"2 s\"), seconds if bare;\n"
         "  TIME is simulated time since the daemon's start.\n"
         "VALUE of write: integers, 0x hex, decimals, \"quoted\" or other text;\n"
         "  TYPE: " + std::string(write_type_names()) + " (bytes: hex like 01:02:ff).\n"
         "\n"
         "Options:\n"
         "  --socket PATH      the daemon's private control socket (peer-to-peer)\n"
         "  --system           the system bus\n"
         "  --user             the user (session) bus\n"
         "                     default: the private socket if it exists ($CANSIM_CONTROL_SOCKET, else\n"
         "                     $XDG_RUNTIME_DIR/cansimd/control, /run/cansimd/control,\n"
         "                     /tmp/cansimd-$UID/control), else the system bus as root, else the user bus\n"
         "  --json             machine-readable output (JSON; watch, monitor: one object per\n"
         "                     line); errors too, on stderr: {\"error\": ..., \"exit_status\": N}\n"
         "  --timeout SECONDS  method call timeout (default 10)\n"
         "  --version          print the version and exit\n"
         "  -h, --help         print this help and exit\n"
         "\n"
         "Exit status: 0 done, 1 refused by the daemon or no connection, 2 bad command line.\n";
  return out;
}

}  // namespace cansim::ctl
