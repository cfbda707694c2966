// Tabulated signals (inline points or CSV), linear or hold interpolation, once or looped.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cansim::physics {

enum class Interpolation : std::uint8_t {
  Linear,  // straight line between points
  Hold,    // value of the last point at or before t (steps)
};

struct TablePoint {
  double t_s;    // time in seconds (simulated time since start)
  double value;  // SI value: Pa for pressure, K for temperature
};

// A table of points. Semantics:
//  * points must have non-decreasing times (two points at the same time = a jump);
//  * before the first point the value is the first point's value;
//  * once (loop = false): after the last point the value holds the last value;
//  * looped: the cycle starts at points.front().t_s and repeats every `period_s`
//    (0 = last time - first time). If period_s is longer than the table, the gap
//    after the last point interpolates back to the first value (Linear) or holds the
//    last value (Hold); at the wrap the value returns to the first point's value.
struct TableSpec {
  std::vector<TablePoint> points;
  Interpolation interpolation = Interpolation::Linear;
  bool loop = false;
  double period_s = 0.0;
};

// Step (value jump) and slope change at one breakpoint of the piecewise-linear signal.
struct TableEvent {
  double t_s;    // absolute time of the breakpoint
  double step;   // value after - value before
  double slope;  // slope after - slope before
};

// Compiled table; evaluation is allocation-free and O(log n).
class Table {
 public:
  Table() = default;
  explicit Table(const TableSpec& spec);  // throws std::invalid_argument on a bad spec

  double value(double t) const;
  // Right derivative d value / dt at t (units per second).
  double slope(double t) const;

  // Calls f(const TableEvent&) for every breakpoint with t - window < t_event <= t,
  // newest first, at most max_events times. Used for response superposition.
  template <class F>
  void for_each_event_back(double t, double window, std::size_t max_events, F&& f) const;

  // Time of the first breakpoint strictly after t (+infinity if none).
  double next_event_time(double t) const;

  bool empty() const { return pts_.empty(); }
  // The smallest and the largest value the table takes (its points': linear
  // and hold interpolation stay between them).
  double min_value() const { return min_; }
  double max_value() const { return max_; }

 private:
  struct Knot {
    double tau;     // offset inside the cycle (or absolute time when not looped)
    double step;    // generic-cycle jump
    double dslope;  // generic-cycle slope change
  };
  double cycle_value(double tau) const;  // tau in [0, period)
  double cycle_slope(double tau) const;

  std::vector<TablePoint> pts_;  // offsets relative to t0_ when looped
  std::vector<Knot> knots_;      // breakpoints of one generic cycle, ascending tau
  Interpolation interp_ = Interpolation::Linear;
  bool loop_ = false;
  double t0_ = 0;
  double period_ = 0;
  double first_step_ = 0;    // the very first cycle's jump at tau 0 (from the pre-start value)
  double first_dslope_ = 0;  // the very first cycle's slope change at tau 0
  double min_ = 0, max_ = 0;
};

// Parse CSV text with two numeric columns (time, value); further columns ignored.
// Separators: ',', ';' or whitespace/tab. Lines starting with '#' and non-numeric
// lines (headers) are skipped. Values are returned as written (the caller converts
// units: time_scale multiplies the time column, value_scale/value_offset map the
// value column: si = raw * value_scale + value_offset).
// On error returns false and sets *error (line number and reason).
bool parse_table_csv(std::string_view text, std::vector<TablePoint>& out, std::string* error, double time_scale = 1.0,
                     double value_scale = 1.0, double value_offset = 0.0);

// ---- template implementation ----
template <class F>
void Table::for_each_event_back(double t, double window, std::size_t max_events, F&& f) const {
  if (knots_.empty() || max_events == 0) return;
  const double t_min = t - window;
  if (!loop_) {
    // Knots are absolute times; find the last knot <= t.
    std::size_t hi = knots_.size();
    std::size_t lo = 0;
    while (lo < hi) {  // first knot with tau > t
      std::size_t mid = (lo + hi) / 2;
      if (knots_[mid].tau <= t) lo = mid + 1;
      else hi = mid;
    }
    std::size_t n = 0;
    for (std::size_t i = lo; i-- > 0 && n < max_events; ++n) {
      if (knots_[i].tau <= t_min) break;
      TableEvent ev{knots_[i].tau, knots_[i].step, knots_[i].dslope};
      if (i == 0) {
        ev.step = first_step_;
        ev.slope = first_dslope_;
      }
      f(static_cast<const TableEvent&>(ev));
    }
    return;
  }
  if (t < t0_) return;
  double cycles = std::floor((t - t0_) / period_);
  long long c = static_cast<long long>(cycles);
  double tau = (t - t0_) - cycles * period_;
  if (tau < 0) tau = 0;
  // Index of the last knot with knot.tau <= tau.
  std::size_t hi = knots_.size();
  std::size_t lo = 0;
  while (lo < hi) {
    std::size_t mid = (lo + hi) / 2;
    if (knots_[mid].tau <= tau) lo = mid + 1;
    else hi = mid;
  }
  std::size_t i = lo;  // next candidate is i-1
  std::size_t n = 0;
  while (n < max_events) {
    if (i == 0) {
      if (c == 0) break;
      --c;
      i = knots_.size();
    }
    --i;
    const double te = t0_ + double(c) * period_ + knots_[i].tau;
    if (te <= t_min) break;
    TableEvent ev{te, knots_[i].step, knots_[i].dslope};
    if (c == 0 && i == 0) {
      ev.step = first_step_;
      ev.slope = first_dslope_;
    }
    f(static_cast<const TableEvent&>(ev));
    ++n;
  }
}

}  // namespace cansim::physics
