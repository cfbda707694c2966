// The daemon's simulated time of a wall-clock instant. Its clock is
// CLOCK_MONOTONIC since its start, so simulated = wall + a constant, which
// one Fleet1.SimulatedTime read between two wall-clock reads gives (to
// within half the round trip). What `cansimctl monitor` stamps frames with:
// the kernel stamps them with the wall clock.
#pragma once

#include "ctl/connection.hpp"

namespace cansim::ctl {

class TimeBase {
 public:
  TimeBase() = default;
  explicit TimeBase(double offset_s) : offset_s_(offset_s) {}
  static TimeBase of(Connection& connection);
  static double wall_now();  // Unix seconds

  double simulated(double wall_s) const { return wall_s + offset_s_; }

 private:
  double offset_s_ = 0;
};

}  // namespace cansim::ctl
