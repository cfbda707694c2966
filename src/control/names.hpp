// The control API's names (docs/control-api.md), shared by the daemon's
// service and its client, cansimctl: bus name, object paths, interfaces and
// error names, and the words of a CHANNEL argument (physics/channel.hpp).
// All versioned ("1"): a new incompatible API gets new names.
#pragma once

#include <optional>
#include <string_view>

#include "physics/channel.hpp"

namespace cansim::control {

using physics::parse_channel;  // "pressure" / "temperature"

inline constexpr const char* kBusName = "io.cansim.Cansimd1";
inline constexpr const char* kRootPath = "/io/cansim/Cansimd1";
inline constexpr const char* kNodePrefix = "/io/cansim/Cansimd1/node";
inline constexpr const char* kFleetInterface = "io.cansim.Fleet1";
inline constexpr const char* kNodeInterface = "io.cansim.Node1";
inline constexpr const char* kPlantPrefix = "/io/cansim/Cansimd1/plant";
inline constexpr const char* kPlantInterface = "io.cansim.Plant1";
// The private socket's stand-in for a message over limits::kMessageBytes
// (control/message_gate.hpp): answered io.cansim.Error.TooLarge.
inline constexpr const char* kGateInterface = "io.cansim.Gate1";
inline constexpr const char* kGateTooLarge = "MessageTooLarge";

inline constexpr const char* kErrorUnknownNode = "io.cansim.Error.UnknownNode";
inline constexpr const char* kErrorUnknownObject = "io.cansim.Error.UnknownObject";
inline constexpr const char* kErrorOutOfRange = "io.cansim.Error.OutOfRange";
inline constexpr const char* kErrorUnknownUnit = "io.cansim.Error.UnknownUnit";
inline constexpr const char* kErrorUnknownChannel = "io.cansim.Error.UnknownChannel";
inline constexpr const char* kErrorUnknownFault = "io.cansim.Error.UnknownFault";
inline constexpr const char* kErrorInvalidArgument = "io.cansim.Error.InvalidArgument";
inline constexpr const char* kErrorNotSupported = "io.cansim.Error.NotSupported";
inline constexpr const char* kErrorRefused = "io.cansim.Error.Refused";
inline constexpr const char* kErrorConfig = "io.cansim.Error.Config";
inline constexpr const char* kErrorTooLarge = "io.cansim.Error.TooLarge";  // over a bound of config/limits.hpp
inline constexpr const char* kErrorUnknownPlant = "io.cansim.Error.UnknownPlant";
inline constexpr const char* kErrorUnknownVariable = "io.cansim.Error.UnknownVariable";  // a plant's variable or input

// Node1.Nmt(s command) and `cansimctl nmt`: a local NMT transition named as
// CiA 301 names the commands (§7.2.8.3.1), or by its short alias.
enum class NmtCommand { kStart, kStop, kPreOperational, kResetNode, kResetCommunication };
struct NmtCommandName {
  NmtCommand command;
  const char* name;   // CiA 301's
  const char* alias;  // the short form
};
inline constexpr NmtCommandName kNmtCommandNames[] = {
    {NmtCommand::kStart, "start", "start"},
    {NmtCommand::kStop, "stop", "stop"},
    {NmtCommand::kPreOperational, "pre-operational", "preop"},
    {NmtCommand::kResetNode, "reset-node", "reset"},
    {NmtCommand::kResetCommunication, "reset-communication", "reset-comm"},
};
// What an error names as the expected words.
inline constexpr const char* kNmtCommandsText =
    "start, stop, pre-operational (preop), reset-node (reset) or reset-communication (reset-comm)";

inline std::optional<NmtCommand> parse_nmt_command(std::string_view word) {
  for (const NmtCommandName& c : kNmtCommandNames)
    if (word == c.name || word == c.alias) return c.command;
  return std::nullopt;
}

}  // namespace cansim::control
