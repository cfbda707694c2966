// D-Bus error names of the control API (docs/control-api.md, "Errors").
#pragma once

namespace cansim::control {

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

}  // namespace cansim::control
