// Object dictionary values <-> D-Bus variants, typed by the entry's CiA 301
// data type (docs/control-api.md, Node1.Read / Write).
#pragma once

#include <systemd/sd-bus.h>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/od.hpp"

namespace cansim::control {

// The D-Bus signature a value of this type travels as ("y", "n", "s", "ay", ...).
const char* dbus_signature(DataType t);

// Appends `bytes` (the entry's encoding) as a variant. Returns sd-bus's result.
int append_value(sd_bus_message* m, const OdEntry& e, std::span<const std::uint8_t> bytes);

// Reads a variant from `m` and encodes it for `e`. On failure returns false
// with `error_name` (io.cansim.Error.*) and a message saying what was expected.
bool read_value(sd_bus_message* m, const OdEntry& e, std::vector<std::uint8_t>& out, std::string& error_name,
                std::string& message);

}  // namespace cansim::control
