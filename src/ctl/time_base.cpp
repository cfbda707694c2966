#include "ctl/time_base.hpp"

#include <ctime>

namespace cansim::ctl {

double TimeBase::wall_now() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return double(ts.tv_sec) + double(ts.tv_nsec) / 1e9;
}

TimeBase TimeBase::of(Connection& connection) {
  const double before = wall_now();
  const double simulated = double(connection.simulated_time_us()) / 1e6;
  const double after = wall_now();
  return TimeBase(simulated - (before + after) / 2);
}

}  // namespace cansim::ctl
