// cansimctl top: the fleet at a glance, refreshed about twice a second.
// ObjectManager.GetManagedObjects gives every node's properties in one call:
// at the start, when nodes come and go, and for each table a pipe or --once
// gets; on a terminal only the rows on screen are read again (Properties.GetAll
// per node: a 1,000-node fleet costs the daemon's loop one page of small calls
// per refresh, not one 1,000-node call), NMT states and EMCY counts follow the
// daemon's signals as they come. The terminal is taken without curses (ANSI
// sequences, raw stdin) and scrolls (arrows, PgUp / PgDn, Home / End; q
// quits). --once prints one table (frames per second over half a second).
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "ctl/connection.hpp"
#include "ctl/json.hpp"
#include "ctl/replies.hpp"

namespace cansim::ctl {

struct TopOptions {
  std::string glob;  // only nodes whose key or name matches (fnmatch), "" : all
  bool once = false;
  bool json = false;
};

int run_top(Connection& connection, const TopOptions& options, std::ostream& out);

// One table row.
struct TopRow {
  std::string key;
  std::uint8_t node_id = 0;
  std::string state;        // NMT state, "off" without power, "... (off the bus)"
  std::string pressure;     // "3.456 / 3.5 bar" (reported / true), "-" without the channel
  std::string temperature;  // "22.5 degC" (reported)
  std::string status;       // 0x6150 of pressure and temperature: "00 00"
  std::string faults;       // active fault kinds, "-"
  std::uint32_t emcy = 0;
  double fps = -1;  // frames per second, < 0 : not known yet
};

// Frames per second of each node from samples of its FramesSent, over the
// last kWindow seconds (a heartbeat-only node reads 1.0, not 0, 2, 0, 2).
class FrameRates {
 public:
  static constexpr double kWindow = 5.0;
  void sample(const std::string& key, std::uint64_t frames, double seconds);  // seconds: any monotonic clock
  double rate(const std::string& key) const;                                  // < 0 : fewer than two samples
 private:
  struct Sample {
    std::uint64_t frames = 0;
    double seconds = 0;
  };
  std::map<std::string, std::deque<Sample>> samples_;
};

// The nodes matching `glob`, in natural order of their keys.
std::vector<NodeStatus> top_nodes(std::vector<NodeStatus> nodes, const std::string& glob);
TopRow top_row(const NodeStatus& node, const FrameRates& rates);

// The header, then rows [first, first + rows) aligned; every row when rows is 0.
std::string format_top_table(const std::vector<TopRow>& rows, std::size_t first = 0, std::size_t count = 0);

// A row with --json: {"node", "node_id", "nmt_state", "powered", "on_bus",
// "pressure", "temperature" (status's readings), "faults", "emcy_count",
// "frames_per_second"}.
Json top_json(const NodeStatus& node, const FrameRates& rates);

// What a terminal of `height` rows and `width` columns shows: the title, a
// blank line, then the table's lines, at most `height` lines in all, each cut
// at `width`, drawn from the top-left corner over the last screen.
std::string top_screen(const std::string& head, const std::string& table, std::size_t height, std::size_t width);

// Does node `key` (vcan0/generic/3, entry name generic) match a top / group glob?
bool glob_matches(const std::string& glob, const std::string& key, const std::string& name);

}  // namespace cansim::ctl
