// Simulated time for the physics layer. The rest of the project counts time in
// int64 microseconds (TimeUs); process models take seconds as double.
// (Defined here so that the physics layer does not depend on core headers.)
#pragma once

#include <cmath>
#include <cstdint>

namespace cansim::physics {

using TimeUs = std::int64_t;

constexpr double us_to_seconds(TimeUs t) noexcept { return static_cast<double>(t) * 1e-6; }
inline TimeUs seconds_to_us(double s) noexcept { return static_cast<TimeUs>(std::llround(s * 1e6)); }

}  // namespace cansim::physics
