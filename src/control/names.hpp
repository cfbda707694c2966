// The control API's names (docs/control-api.md), shared by the daemon's
// service and its client, cansimctl: bus name, object paths, interfaces and
// error names. All versioned ("1"): a new incompatible API gets new names.
#pragma once

namespace cansim::control {

inline constexpr const char* kBusName = "io.cansim.Cansimd1";
inline constexpr const char* kRootPath = "/io/cansim/Cansimd1";
inline constexpr const char* kNodePrefix = "/io/cansim/Cansimd1/node";
inline constexpr const char* kFleetInterface = "io.cansim.Fleet1";
inline constexpr const char* kNodeInterface = "io.cansim.Node1";

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

}  // namespace cansim::control
