#include "daemon/cli.hpp"

#include <algorithm>
#include <iterator>
#include <optional>

#include "config/limits.hpp"
#include "config/yaml_util.hpp"

namespace cansim::daemon {

namespace {

constexpr const char* kLevels[] = {"trace", "debug", "info", "warn", "error", "critical", "off"};

bool parse_number(const std::string& text, std::int64_t& out) { return config::parse_int_literal(text, out); }

}  // namespace

std::string usage_text() {
  return "usage: cansimd --profile FILE|NAME [--interface IF] [--node-id N] [options]\n"
         "       cansimd --config FILE [options]\n"
         "       cansimd --export-eds FILE|NAME [--node-id N] [--strict] [--strict-eds] [--output FILE]\n"
         "       cansimd --export-dbc CONFIG|PROFILE [--interface IF] [--node-id N] [--strict] [--strict-eds] "
         "[--output FILE]\n"
         "\n"
         "Simulates CANopen (CiA 301/305/404) sensor nodes on SocketCAN interfaces.\n"
         "\n"
         "  --profile FILE|NAME  run one node from a profile (path or name in the profiles folder)\n"
         "  --interface IF       CAN interface of that node (default vcan0)\n"
         "  --node-id N          its node-ID, 1..127 or 255 = LSS-unconfigured (default: the profile's)\n"
         "  --config FILE        run the fleet described in FILE\n"
         "  --export-eds FILE|NAME  write the profile's CiA 306 EDS (with --node-id: the DCF of\n"
         "                       that node at power-on) to --output FILE or stdout, and exit\n"
         "  --export-dbc CONFIG|PROFILE  write a DBC of one bus of the fleet (a profile: of one node;\n"
         "                       --interface: which bus, needed when the fleet has several;\n"
         "                       --node-id: the profile's node) to --output FILE or stdout, and exit\n"
         "  --output FILE        where --export-eds / --export-dbc write\n"
         "  --check              validate the configuration and exit (0 valid, 1 invalid)\n"
         "  --strict             every node in strict mode: each vendor deviation at its CiA value\n"
         "                       (options a fleet entry sets still win; with --export-eds: the\n"
         "                       strict device's EDS)\n"
         "  --strict-eds         refuse what the EDS / DCF reader would repair with a warning\n"
         "                       (miscounts, the SDO server's COB-IDs, NodeID=0, ...)\n"
         "  --quirks             with --profile: list the profile's deviations from CiA (option,\n"
         "                       manual reference, faithful and strict value) and exit\n"
         "  --state-dir DIR      stored parameters (default $STATE_DIRECTORY, else ./state)\n"
         "  --log-level LEVEL    trace, debug, info, warn, error, critical or off (default info)\n"
         "  --seed N             fleet random seed (default: the config's, else 1)\n"
         "  --record PATH        CSV of each node's true and reported values (scripts/plot-recording):\n"
         "                       with --profile the file, with --config a folder (one file per node)\n"
         "  --bus BUS            control API on the system, user or no bus: system, user, none,\n"
         "                       auto (default: system when root and there, else user when there)\n"
         "  --control-socket PATH  the control API's private socket, or none (default\n"
         "                       $RUNTIME_DIRECTORY/control, $XDG_RUNTIME_DIR/cansimd/control,\n"
         "                       /run/cansimd/control as root, else /tmp/cansimd-UID/control)\n"
         "  --max-clients N      clients the private socket serves at once, 1..4096 (default 64);\n"
         "                       one more is told why and closed\n"
         "  --address-file FILE  before each READY=1, write FILE (atomically) with one line per\n"
         "                       socketcand bus: NAME HOST PORT (docs/socketcand.md); removed at exit\n"
         "  --socketcand         serve every interface of the fleet as a kernel-free socketcand bus of\n"
         "                       the same name on 127.0.0.1, a free port each, whatever the file says\n"
         "                       (tests on a host without CAN: docs/python.md)\n"
         "  --version            print the version and exit\n"
         "  --help               print this help and exit\n"
         "\n"
         "Signals: SIGHUP reloads the configuration, SIGTERM / SIGINT stop.\n"
         "Runtime control: cansimctl, or D-Bus io.cansim.Cansimd1 (docs/control-api.md).\n";
}

namespace {

// Options without a value.
bool* flag_of(CliOptions& o, const std::string& arg) {
  const std::pair<const char*, bool*> flags[] = {{"--help", &o.help},
                                                 {"-h", &o.help},
                                                 {"--version", &o.version},
                                                 {"--check", &o.check},
                                                 {"--strict", &o.strict},
                                                 {"--quirks", &o.quirks},
                                                 {"--strict-eds", &o.strict_eds},
                                                 {"--socketcand", &o.socketcand}};
  for (const auto& [name, field] : flags)
    if (arg == name) return field;
  return nullptr;
}

// Options with a value, stored as given.
std::string* text_of(CliOptions& o, const std::string& arg) {
  const std::pair<const char*, std::string*> texts[] = {
      {"--profile", &o.profile},       {"--config", &o.config},
      {"--export-eds", &o.export_eds}, {"--export-dbc", &o.export_dbc},
      {"--output", &o.output},         {"--state-dir", &o.state_dir},
      {"--record", &o.record},         {"--address-file", &o.address_file}};
  for (const auto& [name, field] : texts)
    if (arg == name) return field;
  return nullptr;
}

bool is_checked_option(const std::string& arg) {
  for (const char* name :
       {"--interface", "--node-id", "--log-level", "--bus", "--control-socket", "--max-clients", "--seed"})
    if (arg == name) return true;
  return false;
}

// An option whose value is checked: "" or the error.
std::string set_checked(CliOptions& o, const std::string& arg, const std::string& value) {
  std::int64_t v = 0;
  if (arg == "--interface") {
    if (value.empty() || value.size() > 15) return "--interface: expected an interface name of 1..15 characters";
    o.interface = value;
  } else if (arg == "--node-id") {
    if (!parse_number(value, v) || v < 1 || (v > 127 && v != 255))
      return "--node-id: expected 1..127 or 255, got '" + value + "'";
    o.node_id = int(v);
  } else if (arg == "--log-level") {
    if (std::none_of(std::begin(kLevels), std::end(kLevels), [&](const char* l) { return value == l; }))
      return "--log-level: expected trace, debug, info, warn, error, critical or off, got '" + value + "'";
    o.log_level = value;
  } else if (arg == "--bus") {
    if (value != "auto" && value != "system" && value != "user" && value != "none")
      return "--bus: expected auto, system, user or none, got '" + value + "'";
    o.bus = value;
  } else if (arg == "--control-socket") {
    if (value.empty() || value.size() > 107)
      return "--control-socket: expected a socket path of 1..107 characters or none";
    o.control_socket = value;
  } else if (arg == "--max-clients") {
    if (!parse_number(value, v) || v < 1 || std::uint64_t(v) > limits::kMaxClientsCeiling)
      return "--max-clients: expected 1.." + std::to_string(limits::kMaxClientsCeiling) + ", got '" + value + "'";
    o.max_clients = std::size_t(v);
  } else if (arg == "--seed") {
    if (!parse_number(value, v) || value[0] == '-')
      return "--seed: expected a non-negative integer, got '" + value + "'";
    o.seed = std::uint64_t(v);
  }
  return {};
}

// What the options say together: "" or the error.
std::string check_combination(const CliOptions& o, bool have_interface) {
  if (!o.output.empty() && o.export_eds.empty() && o.export_dbc.empty())
    return "--output goes with --export-eds or --export-dbc";
  if (!o.export_dbc.empty()) {
    if (!o.profile.empty() || !o.config.empty() || !o.export_eds.empty() || o.check)
      return "--export-dbc takes a fleet configuration or a profile of its own (no --profile, --config, "
             "--export-eds or --check)";
    return {};
  }
  if (!o.export_eds.empty()) {
    if (!o.profile.empty() || !o.config.empty() || have_interface || o.check)
      return "--export-eds takes a profile of its own (no --profile, --config, --interface or --check)";
    return {};
  }
  if (o.profile.empty() == o.config.empty())
    return o.profile.empty() ? "expected --profile or --config" : "--profile and --config exclude each other";
  if (o.quirks && o.profile.empty()) return "--quirks goes with --profile";
  if (!o.config.empty() && (have_interface || o.node_id))
    return "--interface and --node-id go with --profile (a --config file names its own)";
  return {};
}

}  // namespace

CliResult parse_cli(const std::vector<std::string>& args, const char* state_directory_env) {
  CliResult r;
  CliOptions& o = r.options;
  bool have_interface = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string arg = args[i];
    std::optional<std::string> value;  // --name=value
    if (auto eq = arg.find('='); arg.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
    }
    if (bool* flag = flag_of(o, arg)) {
      if (value) r.error = "option " + arg + " takes no value";
      else *flag = true;
    } else if (std::string* text = text_of(o, arg); text || is_checked_option(arg)) {
      if (!value && i + 1 < args.size()) value = args[++i];
      if (!value) r.error = "option " + arg + " needs a value";
      else if (text) *text = *value;
      else r.error = set_checked(o, arg, *value);
      have_interface |= arg == "--interface";
    } else {
      r.error = arg.rfind("-", 0) == 0 ? "unknown option " + arg : "unexpected argument '" + arg + "'";
    }
    if (!r.error.empty()) return r;
  }
  if (o.help || o.version) return r;
  o.interface_given = have_interface;
  r.error = check_combination(o, have_interface);
  if (!r.error.empty() || !o.export_eds.empty() || !o.export_dbc.empty()) return r;
  if (o.state_dir.empty()) {
    std::string env = state_directory_env ? state_directory_env : "";
    // systemd passes a colon-separated list when several StateDirectory= are set.
    o.state_dir = env.empty() ? "state" : env.substr(0, env.find(':'));
  }
  return r;
}

}  // namespace cansim::daemon
