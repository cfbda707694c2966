// Quantisation helpers for the device representations (CiA 404 0x6130 REAL32,
// 0x7130 INTEGER16, 0x9130 INTEGER32 with decimal digits 0x6132).
//
// Integer views: value x 10^digits, rounded half away from zero, saturated to
// the target type. The input is taken as double; callers that must reproduce a
// device computing in float32 pass `double(float_value)`
// (e.g. float32(1.92) * 100 = 191.99999571 -> 192, as the SMC manual requires).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

namespace cansim::physics {

// 10^digits for digits in [-18, 18] (exact for 0..22 as doubles).
double pow10(int digits);

// Round half away from zero (std::round), inline: without SSE4.1 the compiler
// calls libm for it, on every sample. Exact: below 2^52, x minus its
// truncation is representable; from 2^52 on (and NaN, inf) x is returned.
inline double round_half_away(double x) {
  if (!(std::fabs(x) < 0x1p52)) return x;
  const double t = double(std::int64_t(x));
  const double f = x - t;
  return f >= 0.5 ? t + 1.0 : f <= -0.5 ? t - 1.0 : t;
}

struct DecimalResult {
  std::int64_t value;  // rounded, saturated integer
  bool saturated;      // true if the value was clipped to the type range (or NaN -> 0)
};

// round_half_away(v * 10^digits) saturated to [lo, hi]. NaN maps to 0, saturated.
DecimalResult to_decimal(double v, int digits, std::int64_t lo, std::int64_t hi);

inline DecimalResult to_decimal_i16(double v, int digits) {
  return to_decimal(v, digits, std::numeric_limits<std::int16_t>::min(), std::numeric_limits<std::int16_t>::max());
}
inline DecimalResult to_decimal_i32(double v, int digits) {
  return to_decimal(v, digits, std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::max());
}
// INTEGER24 (CMP): [-8388608, 8388607].
inline DecimalResult to_decimal_i24(double v, int digits) { return to_decimal(v, digits, -8388608, 8388607); }

// Inverse of to_decimal: integer / 10^digits.
inline double from_decimal(std::int64_t v, int digits) { return double(v) / pow10(digits); }

// IEEE-754 single precision (round to nearest even; overflow -> +-inf).
inline float to_float32(double v) { return float(v); }

// Quantise `v` to a multiple of `step` (round half away from zero). step <= 0: identity.
inline double quantize_step(double v, double step) { return step > 0 ? std::round(v / step) * step : v; }

}  // namespace cansim::physics
