// cansimctl monitor: every frame on the fleet's buses (CAN_RAW on a kernel
// interface, a socketcand client on a socketcand bus: ctl/frame_source.hpp), decoded
// with what the daemon knows of each node (frame_decoder.hpp), one line per
// frame, until SIGINT / SIGTERM. The daemon's PdoMappingChanged, NodeAdded /
// NodeRemoved and NodeId changes keep the decoder current; nothing is polled.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "ctl/connection.hpp"

namespace cansim::ctl {

struct MonitorOptions {
  std::vector<std::string> interfaces;  // empty: every interface of the fleet
  std::string node;                     // NODE: only its frames ("" : all)
  bool json = false;                    // one JSON object per line
  double timeout_s = 10;                // connecting to a socketcand bus
};

int run_monitor(Connection& connection, const MonitorOptions& options, std::ostream& out);

// The label people name a node by: its entry name, or name/INDEX when a
// count: group shares the name (what GetNode accepts).
std::string node_label(const std::string& name, std::uint32_t index, bool name_shared);

}  // namespace cansim::ctl
