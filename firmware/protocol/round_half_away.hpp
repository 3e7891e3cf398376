// std::round (halves away from zero) without the libm call: the fragmenter rounds three
// coordinates per point, and the out-of-line call was the largest single cost of fragmenting.
// Bit-identical to std::round for every double (tests/unit/udp_protocol/quantize_test.cpp).
#pragma once

#include <cmath>
#include <cstdint>

namespace v2xloc::protocol {

// std::round(x) as an integer, for |x| < 2^52 (callers check the range first).
inline std::int64_t round_half_away_to_integer(double x) {
  const std::int64_t truncated = static_cast<std::int64_t>(x);
  const double fraction = x - static_cast<double>(truncated);  // exact: x's own low-order bits
  return truncated + (fraction >= 0.5 ? 1 : 0) - (fraction <= -0.5 ? 1 : 0);
}

inline double round_half_away(double x) {
  // From 2^52 up every double is an integer; NaN and inf also go here (x + 0.0 quiets a
  // signalling NaN, as std::round does).
  if (!(std::fabs(x) < 0x1p52)) return x + 0.0;
  // std::round keeps the sign of zero: round(-0.3) == -0.0.
  return std::copysign(static_cast<double>(round_half_away_to_integer(x)), x);
}

}  // namespace v2xloc::protocol
