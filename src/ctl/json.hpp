// cansimctl --json: values are nlohmann::ordered_json (members in the order
// they are added), each document written on its own line. The member names
// are one vocabulary shared by every verb (docs/cansimctl.md): `node` is a
// node's fleet key, `time` simulated seconds, `wall_time` Unix seconds,
// `kind` what a record is, `fields` a decoded frame's or signal's values,
// bytes are hex text ("0102ff"), a missing value is null.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>

#include "ctl/values.hpp"

namespace cansim::ctl {

using Json = nlohmann::ordered_json;

// A measured number: NaN and infinities are null; a value that is exactly a
// float (a REAL32 object) is that float's shortest text (0.1f is 0.1, not
// 0.10000000149011612).
Json json_number(double d);

// A value as Read returns it: numbers and booleans as themselves, strings as
// they are, bytes as hex text.
Json json_value(const Value& v);

// Text, or null when it is empty.
Json json_text_or_null(const std::string& text);

// Simulated time in µs as seconds; negative (none) is null.
Json json_seconds(std::int64_t us);

// One document on its own line; bytes that are not UTF-8 are replaced, not thrown.
void print_json(std::ostream& out, const Json& document);

}  // namespace cansim::ctl
