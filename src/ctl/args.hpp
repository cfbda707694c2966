// cansimctl command line: global options, then a verb and its arguments.
// A bad command line throws UsageError (main prints it with the usage, exit 2).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "ctl/request.hpp"

namespace cansim::ctl {

// `verb`: the command the line is for ("" when none is known): its usage is
// printed instead of the whole usage.
class UsageError : public std::runtime_error {
 public:
  explicit UsageError(const std::string& what, std::string verb = "")
      : std::runtime_error(what), verb(std::move(verb)) {}
  std::string verb;
};

enum class BusKind {
  kDefault,  // the private socket if it exists, else the system bus as root, else the user bus
  kSocket,   // --socket PATH: peer-to-peer
  kSystem,   // --system
  kUser,     // --user
};

struct GlobalOptions {
  BusKind bus = BusKind::kDefault;
  std::string socket;       // --socket PATH
  bool json = false;        // --json
  double timeout_s = 10.0;  // --timeout SECONDS
  bool help = false;        // -h, --help
  bool version = false;     // --version
};

struct CommandLine {
  GlobalOptions global;
  std::string help_verb;  // `VERB --help`, `help VERB`: that command's help
  Request request;        // unset when help or version was asked for
};

// args excludes argv[0].
CommandLine parse_command_line(const std::vector<std::string>& args);

std::string usage_text();
// "usage: cansimctl set NODE CHANNEL VALUE UNIT [--ramp DURATION]\n" and a
// pointer to the verb's help: what a bad line of that verb prints.
std::string verb_usage(const std::string& verb);
// The verb's usage, what it does and the forms of its arguments.
std::string verb_help(const std::string& verb);
// Every verb, in the order of the usage.
std::vector<std::string> verb_names();

}  // namespace cansim::ctl
