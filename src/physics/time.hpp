// Simulated time for the physics layer. The rest of the project counts time in
// int64 microseconds (TimeUs); process models take seconds as double.
// (Defined here so that the physics layer does not depend on core headers.)
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

namespace cansim::physics {

using TimeUs = std::int64_t;
inline constexpr TimeUs kNever = std::numeric_limits<TimeUs>::max();

constexpr double us_to_seconds(TimeUs t) { return double(t) * 1e-6; }
inline TimeUs seconds_to_us(double s) { return TimeUs(std::llround(s * 1e6)); }

}  // namespace cansim::physics
