// What one cansimctl command asks of the daemon: a method call of the control
// API (docs/control-api.md) and how to print its reply. Pure data, built by
// parse_command_line (args.hpp) and carried out by run_request (commands.hpp).
#pragma once

#include <map>
#include <string>
#include <variant>
#include <vector>

#include "control/names.hpp"
#include "ctl/values.hpp"

namespace cansim::ctl {

using control::kBusName;
using control::kFleetInterface;
using control::kNodeInterface;
using control::kPlantInterface;
inline constexpr const char* kFleetPath = control::kRootPath;
inline constexpr const char* kNodePathPrefix = control::kNodePrefix;
inline constexpr const char* kPropertiesInterface = "org.freedesktop.DBus.Properties";

using StringMap = std::map<std::string, std::string>;  // "a{ss}"

// An argument sent as a D-Bus variant "v" (Write's value).
struct Variant {
  Value value;
  bool operator==(const Variant&) const = default;
};

using Arg = std::variant<Value, Variant, StringMap>;

enum class Target {
  kFleet,  // the fleet object
  kNode,   // the object path GetNode returns for Request::node
};

struct Call {
  Target target = Target::kFleet;
  std::string interface;
  std::string method;
  std::vector<Arg> args;
  bool operator==(const Call&) const = default;
};

// How the reply is printed (and, for kWatch and kAdded, what happens around
// the call).
enum class Output {
  kNothing,
  kNodes,    // ListNodes
  kStatus,   // Properties.GetAll of a node
  kFaultId,  // ArmFault
  kFaults,   // ListFaults
  kValue,    // Read
  kAdded,    // AddNodes: its argument is the text of Request::file
  kTime,     // Properties.Get SimulatedTime
  kStats,    // GetBusStatistics
  kDcf,      // GetDcf: written to Request::file, or printed when it is ""
  kWatch,    // Subscribe, then print signals until SIGINT/SIGTERM (only Request::node's, if given)
  kMonitor,  // decode the frames of Request::interfaces (all: none given) until SIGINT/SIGTERM
  kTop,      // the fleet table (Request::pattern, Request::once) until q / SIGINT / SIGTERM
  kCapture,  // the frames of Request::interfaces[0] to Request::file (candump -L) until SIGINT/SIGTERM
  kReplay,   // Request::file onto Request::interfaces[0] (Fleet1.QueueFrames), Request::replay
  kPlant,    // a plant's (Request::node) or every plant's variables and inputs; with Call::method, Set / Override /
             // ClearOverride
};

// replay's options (ctl/capture_replay.hpp).
struct ReplaySettings {
  bool loop = false;
  bool filtered = false;
  std::uint32_t filter_id = 0, filter_mask = 0;
  double speed = 1.0;
  bool operator==(const ReplaySettings&) const = default;
};

struct Request {
  std::string verb;  // the command ("set"), for its usage after a usage-level refusal
  std::string node;  // NODE as given on the command line, "" when none
  Call call;
  Output output = Output::kNothing;
  std::string file;                     // kAdded: read; kDcf: written
  ObjectAddress object;                 // kValue
  std::vector<std::string> interfaces;  // kMonitor; kCapture, kReplay: the bus
  ReplaySettings replay;                // kReplay
  std::string pattern;                  // kTop: GLOB
  bool once = false;                    // kTop
  bool group = false;                   // node may name several nodes (glob, ID range, count: group)
};

}  // namespace cansim::ctl
