// std::round (halves away from zero) without the libm call: the fragmenter rounds three
// coordinates per point, and the out-of-line call was the largest single cost of fragmenting.
// Bit-identical to std::round for every double (tests/unit/udp_protocol/round_half_away_test.cpp).
#pragma once

#include <cmath>
#include <cstdint>

namespace v2xloc::protocol {

inline double round_half_away(double x) {
  // From 2^52 up every double is an integer; NaN and inf also go here (x + 0.0 quiets a
  // signalling NaN, as std::round does).
  if (!(std::fabs(x) < 0x1p52)) return x + 0.0;
  const double truncated = static_cast<double>(static_cast<std::int64_t>(x));
  const double fraction = x - truncated;  // exact: it is x's own low-order bits
  double r = truncated;
  if (fraction >= 0.5) r += 1.0;
  if (fraction <= -0.5) r -= 1.0;
  return std::copysign(r, x);  // std::round keeps the sign of zero: round(-0.3) == -0.0
}

}  // namespace v2xloc::protocol
