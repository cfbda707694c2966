// cansimctl capture and replay (docs/socketcand.md "Record and replay").
//
// capture BUS FILE: every frame on the bus (a CAN_RAW socket on a kernel
// interface, a socketcand client on a socketcand bus: ctl/frame_source.hpp)
// to FILE in candump -L format (ctl/candump.hpp; "-": stdout), flushed after
// every read, until SIGINT / SIGTERM.
//
// replay FILE --on BUS: the file's frames onto the bus as an outside
// participant, through the daemon (Fleet1.QueueFrames): the daemon submits
// each at its time, so a timed bus arbitrates them with the nodes' frames,
// and a kernel interface gets them written as the nodes' are. Times keep the
// file's spacing (divided by --speed), starting 100 ms after the call; frames
// are handed over at most 1 s ahead, in batches of at most 512 (the daemon
// takes what fits in its bounded queue, the rest follows). --loop plays the
// file again after its last frame, one mean frame gap later. --filter
// ID[:MASK] keeps the frames whose identifier matches (hex, as candump's
// filters). Error and CAN FD frames are not replayed (counted).
#pragma once

#include <cstdint>
#include <ostream>
#include <string>

#include "ctl/connection.hpp"

namespace cansim::ctl {

struct CaptureOptions {
  std::string bus;
  std::string file;  // "-": stdout
  double timeout_s = 10;
};
int run_capture(Connection& connection, const CaptureOptions& options, std::ostream& err);

struct ReplayOptions {
  std::string file;
  std::string bus;
  bool loop = false;
  bool filtered = false;
  std::uint32_t filter_id = 0, filter_mask = 0;
  double speed = 1.0;
  bool json = false;  // the summary as {"interface", "file", "frames", "filtered", "skipped"}
};
int run_replay(Connection& connection, const ReplayOptions& options, std::ostream& out);

}  // namespace cansim::ctl
