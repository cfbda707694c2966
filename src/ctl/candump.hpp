// candump's log format (can-utils `candump -L`, read by canplayer and
// python-can's can.LogReader): one frame a line,
//   (1700000000.123456) vcan0 185#01AB
// the time in seconds since the epoch with microseconds, the interface, the
// identifier (3 hex digits, 8 for a 29-bit one or an error frame with
// CAN_ERR_FLAG), `#`, the data in hex; a remote frame `#R` with its DLC when
// not 0 (`711#R1`). Pure: cansimctl capture writes it, replay reads it.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "ctl/frame_decoder.hpp"

namespace cansim::ctl {

std::string candump_line(const RawFrame& frame);  // with its newline

// One line as a frame to replay (its interface the file's) and its time
// (µs since the epoch; frame.time too). False for
// what is not one, with `why`: a blank line or comment ("" why), an error or
// CAN FD frame ("not replayed: ..."), a malformed line.
bool parse_candump_line(std::string_view line, std::int64_t& time_us, RawFrame& frame, std::string& why);

}  // namespace cansim::ctl
