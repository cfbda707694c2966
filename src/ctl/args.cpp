#include <cctype>
#include "ctl/args.hpp"

#include "control/names.hpp"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <charconv>
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
  if (!control::parse_channel(word)) throw UsageError("channel must be pressure or temperature, got " + quoted(word));
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
  if (w.has("--off")) {
    if (w.size() > 2) throw UsageError("override takes NODE CHANNEL VALUE UNIT, or NODE [CHANNEL] --off");
    return on_node(w, node_call("ClearOverride", {text(w.size() == 2 ? channel(w[1]) : "")}));
  }
  if (w.size() != 4) throw UsageError("override takes NODE CHANNEL VALUE UNIT, or NODE [CHANNEL] --off");
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

// The Python client's Node.power_cycle() has the same default.
constexpr double kPowerCycleOffSeconds = 0.5;

Request build_power_cycle(const Words& w) {
  const std::string* off = w.option("--off");
  return on_node(w, node_call("PowerCycle", {real(off ? duration_seconds(*off) : kPowerCycleOffSeconds)}));
}

// The CiA 301 name goes to the daemon, whichever form was typed.
Request build_nmt(const Words& w) {
  const auto command = control::parse_nmt_command(w[1]);
  if (!command)
    throw UsageError("NMT command must be " + std::string(control::kNmtCommandsText) + ", got " + quoted(w[1]));
  for (const control::NmtCommandName& c : control::kNmtCommandNames)
    if (c.command == *command) return on_node(w, node_call("Nmt", {text(c.name)}));
  return {};
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

Request build_remove(const Words& w) {
  Request r = on_fleet(fleet_call("RemoveNode", {text(w[0])}));
  r.node = w[0];  // the answer names its key
  return r;
}

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

// plant [NAME [set INPUT VALUE [UNIT] | override INPUT VALUE [UNIT] | override INPUT --off]]
Request build_plant(const Words& w) {
  Request r;
  r.output = Output::kPlant;
  if (w.size() > 0) r.node = w[0];
  const bool off = w.has("--off");
  if (w.size() <= 1) {
    if (off) throw UsageError("--off goes with override INPUT");
    return r;
  }
  const std::string& action = w[1];
  if (action != "set" && action != "override")
    throw UsageError("expected set or override after the plant's name, got " + quoted(action));
  if (off) {
    if (action != "override" || w.size() != 3) throw UsageError("override INPUT --off takes no value");
    r.call = {Target::kFleet, kPlantInterface, "ClearOverride", {text(w[2])}};
    return r;
  }
  if (w.size() < 4) throw UsageError(action + " takes INPUT VALUE [UNIT]");
  r.call = {Target::kFleet,
            kPlantInterface,
            action == "set" ? "Set" : "Override",
            {text(w[2]), real(number(w[3])), text(w.size() > 4 ? w[4] : "")}};
  return r;
}

Request build_capture(const Words& w) {
  Request r;
  r.output = Output::kCapture;
  r.interfaces = {w[0]};
  r.file = w[1];
  return r;
}

// A CAN identifier in hex, as candump's filters write it (0x allowed).
std::uint32_t can_id_word(std::string_view s, const char* what) {
  if (s.rfind("0x", 0) == 0 || s.rfind("0X", 0) == 0) s.remove_prefix(2);
  std::uint32_t v = 0;
  auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v, 16);
  if (s.empty() || ec != std::errc{} || end != s.data() + s.size() || v > 0x1FFFFFFF)
    throw UsageError(std::string("--filter: expected ") + what + " in hex, at most 1FFFFFFF (181:7FF)");
  return v;
}

Request build_replay(const Words& w) {
  Request r;
  r.output = Output::kReplay;
  r.file = w[0];
  const std::string* on = w.option("--on");
  if (!on || on->empty()) throw UsageError("replay: --on BUS is required");
  r.interfaces = {*on};
  r.replay.loop = w.has("--loop");
  if (const std::string* f = w.option("--filter")) {
    const std::size_t colon = f->find(':');
    r.replay.filtered = true;
    r.replay.filter_id = can_id_word(std::string_view(*f).substr(0, colon), "an identifier");
    r.replay.filter_mask =
        colon == std::string::npos ? 0x1FFFFFFFu : can_id_word(std::string_view(*f).substr(colon + 1), "a mask");
  }
  if (const std::string* x = w.option("--speed")) {
    const auto v = parse_real(*x);
    if (!v || !(*v > 0) || *v > 1000)
      throw UsageError("--speed: expected a factor above 0, at most 1000 (2: twice as fast)");
    r.replay.speed = *v;
  }
  return r;
}

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
      {"set",
       "NODE CHANNEL VALUE UNIT [--ramp DURATION]",
       "set the true value: at once, or ramping there over DURATION",
       4,
       4,
       {{"--ramp", true}},
       build_set,
       kGroups},
      {"hold", "NODE CHANNEL", "keep the true value at its present level", 2, 2, {}, build_hold},
      {"model",
       "NODE CHANNEL YAML",
       "replace the process model (YAML as in the profile's physics:)",
       3,
       3,
       {},
       build_model},
      {"restore-model", "NODE CHANNEL", "back to the profile's process model", 2, 2, {}, build_restore_model},
      {"override",
       "NODE CHANNEL VALUE UNIT | NODE [CHANNEL] --off",
       "report VALUE whatever the sensor measures; --off: stop doing so (on every channel without CHANNEL)",
       1,
       4,
       {{"--off", false}},
       build_override,
       kGroups},
      {"fault",
       "NODE KIND [--for DURATION] [--at TIME] [KEY=VALUE...]",
       "arm a fault (kind and keys as in a profile's faults:), print its id",
       2,
       kAny,
       {{"--for", true}, {"--at", true}},
       build_fault,
       kGroups},
      {"faults", "NODE", "list the armed faults", 1, 1, {}, build_faults},
      {"cancel", "NODE ID", "end fault ID", 2, 2, {}, build_cancel, kGroups},
      {"power-cycle",
       "NODE [--off DURATION]",
       "power off, on again after DURATION (default 0.5 s; 0: reboot)",
       1,
       1,
       {{"--off", true}},
       build_power_cycle,
       kGroups},
      {"nmt",
       "NODE start|stop|pre-operational|reset-node|reset-communication",
       "a local NMT transition (aliases: preop, reset, reset-comm)",
       2,
       2,
       {},
       build_nmt,
       kGroups},
      {"read", "NODE INDEX[:SUB]", "read an object (0x6130:1, 1017h, 4119; SUB default 0)", 2, 2, {}, build_read},
      {"write",
       "NODE INDEX[:SUB] VALUE [--type TYPE]",
       "write an object; VALUE typed by its look unless TYPE is given",
       3,
       3,
       {{"--type", true}},
       build_write},
      {"record",
       "NODE PATH | --stop",
       "record true and reported values to a CSV file",
       1,
       2,
       {{"--stop", false}},
       build_record},
      {"store", "NODE [SUB]", "save parameters as a write of 0x1010:SUB (default 1: all)", 1, 2, {}, build_store},
      {"restore", "NODE [SUB]", "restore defaults as a write of 0x1011:SUB (default 1: all)", 1, 2, {}, build_restore},
      {"dcf",
       "NODE [--output FILE]",
       "the node's CiA 306 DCF (current values), printed or written to FILE",
       1,
       1,
       {{"--output", true}},
       build_dcf},
      {"watch", "[NODE]", "print events and property changes until Ctrl-C", 0, 1, {}, build_watch},
      {"monitor",
       "[IFACE...] [--node NODE]",
       "print every frame decoded (PDO values in engineering units, SDO, NMT, EMCY...) until Ctrl-C",
       0,
       kAny,
       {{"--node", true}},
       build_monitor},
      {"top",
       "[GLOB] [--once]",
       "the fleet at a glance, refreshed twice a second (GLOB: keys or names like 'generic/*'); --once: one table",
       0,
       1,
       {{"--once", false}},
       build_top},
      {"add", "FILE.yaml", "add the nodes of a fleet YAML fragment, print them", 1, 1, {}, build_add},
      {"remove", "NODE", "remove a node", 1, 1, {}, build_remove},
      {"reload", "", "re-read the configuration file (as SIGHUP)", 0, 0, {}, build_reload},
      {"time", "", "print the simulated time", 0, 0, {}, build_time},
      {"stats", "", "per-interface bus statistics", 0, 0, {}, build_stats},
      {"capture",
       "BUS FILE",
       "record every frame on BUS to FILE (- : stdout) in candump -L format until Ctrl-C",
       2,
       2,
       {},
       build_capture},
      {"replay",
       "FILE --on BUS [--loop] [--filter ID[:MASK]] [--speed X]",
       "play a candump -L file onto BUS as one more participant of the bus",
       1,
       1,
       {{"--on", true}, {"--loop", false}, {"--filter", true}, {"--speed", true}},
       build_replay},
      {"plant",
       "[NAME [set|override INPUT VALUE [UNIT] | override INPUT --off]]",
       "a plant's variables and inputs (age, source) in units, every plant without NAME; set or override an input",
       0,
       5,
       {{"--off", false}},
       build_plant},
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
       "UNIT: bar, mbar, psi, Pa, kPa, MPa (pressure); degC, degF, K (temperature);\n"
       "  a plant's input: any unit of its kind (%, g/s, Nl/min, W, ...: docs/plants.md).\n"},
      {[](const VerbSpec& v) { return mentions(v, "DURATION") || mentions(v, "TIME"); },
       "DURATION, TIME: a number and s, ms, us, min or h (\"500ms\", \"2 s\"), seconds if bare;\n"
       "  TIME is simulated time since the daemon's start.\n"},
      {[](const VerbSpec& v) { return mentions(v, "KIND"); },
       "KIND: open, short, stuck, drift, spikes, noise_burst, over_temperature,\n"
       "  eeprom_error, silent, power_cycle, bus_off, heartbeat_stop, slow_sdo,\n"
       "  sdo_block_drop; network: frame_drop, frame_delay, frame_freeze,\n"
       "  frame_corrupt, frame_dlc, frame_duplicate, node_id_collision, babbling,\n"
       "  sdo_abort, sdo_silent, sdo_toggle_error, clock_drift, error_frames;\n"
       "  KEY=VALUE as in a profile's faults: (value=2 bar, drift=0.5 bar,\n"
       "  channel=temperature, count=3, period=1 s, service=tpdo1, cob_id=0x181,\n"
       "  probability=0.5, delay=20ms, code=0x06020000, class=passive, ...).\n"
       "  On a plant (NODE plant:NAME): leak, blocked, valve_stuck, input_lost with\n"
       "  target=BLOCK or INPUT (leak: kv=0.05 or flow=2 g/s).\n"},
      {[](const VerbSpec& v) { return v.name == "plant"; },
       "NAME: a plant of the fleet's plants: section. INPUT: one of its inputs; VALUE in\n"
       "  UNIT (default: the input's own). set: a value as if its source sent it; override:\n"
       "  the input is VALUE whatever its source says, until override INPUT --off.\n"},
      {[](const VerbSpec& v) { return mentions(v, "INDEX"); },
       "INDEX[:SUB]: 0x6130:1, 1017h, 4119 (SUB 0 when omitted). read prints a process\n"
       "  value with its unit (3.5 bar; an integer view as 350 (0x15e) = 3.50 bar).\n"},
      {[](const VerbSpec& v) { return v.name == "write"; },
       "VALUE: integers, 0x hex, decimals, \"quoted\" or other text, typed by its look;\n"
       "  --type bool u8 u16 u32 u64 i8 i16 i32 i64 f32 f64 str bytes (bytes: 01:02:ff).\n"},
      {[](const VerbSpec& v) { return mentions(v, "GLOB"); }, "GLOB: keys or names: 'generic/*', 'vcan1/*', 'dps'.\n"},
      {[](const VerbSpec& v) { return mentions(v, "IFACE"); },
       "IFACE: CAN interfaces to listen on (default: every interface of the fleet; a\n"
       "  socketcand bus is read as one of its clients).\n"},
      {[](const VerbSpec& v) { return v.name == "capture"; },
       "BUS: a kernel interface (read with CAN_RAW, kernel receive times) or a socketcand\n"
       "  bus of the fleet (read as one of its clients). FILE: candump -L lines,\n"
       "  (1700000000.123456) BUS 185#01AB, for canplayer and python-can's can.LogReader;\n"
       "  flushed after every read; a line on stderr says how many at the end.\n"},
      {[](const VerbSpec& v) { return v.name == "replay"; },
       "FILE: candump -L lines (cansimctl capture, candump -L); every frame of it, whatever\n"
       "  its interface, goes onto BUS through cansimd (Fleet1.QueueFrames): on a timed bus\n"
       "  it arbitrates with the nodes' frames, a kernel interface gets it written.\n"
       "  Error and CAN FD frames are skipped. The file's spacing is kept from 100 ms\n"
       "  after the call; the command ends when its last frame had its time.\n"
       "--loop: again and again, one mean frame gap after the last frame, until Ctrl-C.\n"
       "--filter ID[:MASK]: only frames with (identifier & MASK) == (ID & MASK), in hex\n"
       "  (181:7FF; MASK default 1FFFFFFF). --speed X: X times as fast (0.5: half).\n"},
  };
  return kHelp;
}

std::string arguments_text(std::size_t n) { return n == 1 ? "1 argument" : std::to_string(n) + " arguments"; }

std::string count_error(const VerbSpec& v, std::size_t given) {
  const std::string expected = v.min_words == v.max_words ? std::to_string(v.min_words)
                               : v.max_words == kAny
                                   ? "at least " + std::to_string(v.min_words)
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
      if (verb) words.positional.push_back(arg);
      else verb = &find_verb(arg);
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
  line.request.verb = verb->name;
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
  out +=
      "\n"
      "NODE: a node's name (dps, or generic/1 in a count: group), its fleet key\n"
      "  (vcan0/dps/0) or IFACE/ID (vcan0/0x10); set, override, fault, cancel,\n"
      "  power-cycle and nmt also take several: a glob ('generic/*'), an ID range\n"
      "  (vcan0/0x10-0x13) or a count: group's name (generic). fault, faults and\n"
      "  cancel take a plant as plant:NAME.\n"
      "CHANNEL: pressure or temperature. UNIT: bar, mbar, psi, Pa, kPa, MPa, degC, degF, K.\n"
      "DURATION, TIME: a number and s, ms, us, min or h (\"500ms\", \"2 s\"), seconds if bare;\n"
      "  TIME is simulated time since the daemon's start.\n"
      "VALUE of write: integers, 0x hex, decimals, \"quoted\" or other text;\n"
      "  TYPE: " +
      std::string(write_type_names()) +
      " (bytes: hex like 01:02:ff).\n"
      "\n"
      "Options:\n"
      "  --socket PATH      the daemon's private control socket (peer-to-peer)\n"
      "  --system           the system bus\n"
      "  --user             the user (session) bus\n"
      "                     default: the private socket if it exists ($CANSIM_CONTROL_SOCKET, else\n"
      "                     $XDG_RUNTIME_DIR/cansimd/control, /run/cansimd/control,\n"
      "                     /tmp/cansimd-$UID/control), else the system bus as root, else the user bus\n"
      "  --json             machine-readable output, one vocabulary across commands\n"
      "                     (docs/cansimctl.md); acting commands answer {\"node\": ..., \"ok\": true};\n"
      "                     watch, monitor: one object per line; errors too, on stderr:\n"
      "                     {\"error\": ..., \"name\": ..., \"exit_status\": N}\n"
      "  --timeout SECONDS  method call timeout (default 10)\n"
      "  --version          print the version and exit\n"
      "  -h, --help         print this help and exit\n"
      "\n"
      "Exit status: 0 done, 1 refused by the daemon or no connection, 2 bad command line (a word\n"
      "the daemon does not know as a unit, fault kind or argument value included).\n";
  return out;
}

}  // namespace cansim::ctl
