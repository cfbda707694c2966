#include "physics/quantize.hpp"

namespace cansim::physics {

double pow10(int digits) {
  static constexpr double kPos[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8, 1e9,
                                    1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18};
  if (digits >= 0) return digits <= 18 ? kPos[digits] : std::pow(10.0, digits);
  return digits >= -18 ? 1.0 / kPos[-digits] : std::pow(10.0, digits);
}

DecimalResult to_decimal(double v, int digits, std::int64_t lo, std::int64_t hi) {
  if (std::isnan(v)) return {0, true};
  // Multiply (or divide, for negative digits, to keep exactness of 10^k).
  const double scaled = digits >= 0 ? v * pow10(digits) : v / pow10(-digits);
  const double r = round_half_away(scaled);
  if (r < double(lo)) return {lo, true};
  if (r > double(hi)) return {hi, true};
  return {std::int64_t(r), false};
}

}  // namespace cansim::physics
