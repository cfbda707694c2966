// Offered traffic of a fleet, estimated from each node's OD (heartbeat
// producer time, TPDO event timers and SYNC-driven TPDOs), against what a bus
// of a given bit rate can carry. Frame sizes per ISO 11898-1: a standard data
// frame is 47 + 8*dlc bits without stuffing (111 bits for 8 bytes; 9,009
// frames/s at 1 Mbit/s), worst-case bit stuffing adds one bit per 4 of the
// 34 + 8*dlc stuffable bits (135 bits for 8 bytes).
#pragma once

#include <cstdint>

#include "core/node.hpp"

namespace cansim::daemon {

struct Traffic {
  double frames_per_s = 0;
  double bits_per_s = 0;          // without stuffing
  double stuffed_bits_per_s = 0;  // worst case
  Traffic& operator+=(const Traffic& o) {
    frames_per_s += o.frames_per_s;
    bits_per_s += o.bits_per_s;
    stuffed_bits_per_s += o.stuffed_bits_per_s;
    return *this;
  }
};

int frame_bits(int dlc, bool extended = false);
int stuffed_frame_bits(int dlc, bool extended = false);
// What one node offers per second, from its current OD values.
Traffic estimate_traffic(const Node& node);

}  // namespace cansim::daemon
