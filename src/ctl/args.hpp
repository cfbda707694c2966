// cansimctl command line: global options, then a verb and its arguments.
// A bad command line throws UsageError (main prints it with the usage, exit 2).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "ctl/request.hpp"

namespace cansim::ctl {

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
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
  Request request;  // unset when help or version was asked for
};

// args excludes argv[0].
CommandLine parse_command_line(const std::vector<std::string>& args);

std::string usage_text();

}  // namespace cansim::ctl
