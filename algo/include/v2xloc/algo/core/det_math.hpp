// Deterministic elementary functions built from +, -, *, / and sqrt only (all IEEE-754 exact
// roundings), so x86-64, aarch64 and Cortex-R produce the same bits; libm's sin/atan2 may
// dispatch to FMA variants at run time and differ in the last ulp between machines.
// Accuracy: about 1e-16 relative on the reduced ranges (Taylor series with enough terms).
#pragma once

#include <cmath>
#include <cstdint>

namespace v2xloc::det {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kHalfPi = 1.57079632679489661923;

namespace detail {
// Cody-Waite split of pi/2 so that x - k*pi/2 stays exact for |k| < 2^20.
inline constexpr double kPio2Hi = 1.57079632673412561417e+00;
inline constexpr double kPio2Mid = 6.07710050650619224932e-11;
inline constexpr double kPio2Lo = 2.02226624879595063154e-21;

// sin(r), cos(r) for |r| <= pi/4, Taylor to r^19 / r^18 (remainder < 1e-19).
inline double sin_reduced(double r) {
  const double r2 = r * r;
  double p = -1.0 / 121645100408832000.0;   // -1/19!
  p = p * r2 + 1.0 / 355687428096000.0;     // 1/17!
  p = p * r2 - 1.0 / 1307674368000.0;       // -1/15!
  p = p * r2 + 1.0 / 6227020800.0;          // 1/13!
  p = p * r2 - 1.0 / 39916800.0;            // -1/11!
  p = p * r2 + 1.0 / 362880.0;              // 1/9!
  p = p * r2 - 1.0 / 5040.0;                // -1/7!
  p = p * r2 + 1.0 / 120.0;                 // 1/5!
  p = p * r2 - 1.0 / 6.0;                   // -1/3!
  return r + r * r2 * p;
}
inline double cos_reduced(double r) {
  const double r2 = r * r;
  double p = 1.0 / 6402373705728000.0;      // 1/18!
  p = p * r2 - 1.0 / 20922789888000.0;      // -1/16!
  p = p * r2 + 1.0 / 87178291200.0;         // 1/14!
  p = p * r2 - 1.0 / 479001600.0;           // -1/12!
  p = p * r2 + 1.0 / 3628800.0;             // 1/10!
  p = p * r2 - 1.0 / 40320.0;               // -1/8!
  p = p * r2 + 1.0 / 720.0;                 // 1/6!
  p = p * r2 - 1.0 / 24.0;                  // -1/4!
  p = p * r2 + 0.5;                         // 1/2!
  return 1.0 - r2 * p;
}
// Reduces x to r in [-pi/4, pi/4] and returns the quadrant k mod 4.
inline int reduce_quadrant(double x, double& r) {
  const double k = std::nearbyint(x * (1.0 / kHalfPi));  // round-to-nearest-even, exact op
  r = ((x - k * kPio2Hi) - k * kPio2Mid) - k * kPio2Lo;
  const long long ki = static_cast<long long>(k);
  return static_cast<int>(ki & 3);
}
// atan(t) for |t| <= tan(pi/12) ~ 0.268, alternating series to t^31 (remainder < 1e-19).
inline double atan_reduced(double t) {
  const double t2 = t * t;
  double p = 0.0;
  for (int n = 15; n >= 1; --n) {
    const double term = 1.0 / (2.0 * n + 1.0);
    p = p * t2 + ((n & 1) ? -term : term);
  }
  return t + t * t2 * p;
}
}  // namespace detail

inline double sin(double x) {
  if (!std::isfinite(x)) return x - x;  // NaN
  double r;
  switch (detail::reduce_quadrant(x, r)) {
    case 0: return detail::sin_reduced(r);
    case 1: return detail::cos_reduced(r);
    case 2: return -detail::sin_reduced(r);
    default: return -detail::cos_reduced(r);
  }
}

inline double cos(double x) {
  if (!std::isfinite(x)) return x - x;
  double r;
  switch (detail::reduce_quadrant(x, r)) {
    case 0: return detail::cos_reduced(r);
    case 1: return -detail::sin_reduced(r);
    case 2: return -detail::cos_reduced(r);
    default: return detail::sin_reduced(r);
  }
}

inline double atan(double x) {
  if (std::isnan(x)) return x;
  const bool negative = x < 0.0;
  double a = negative ? -x : x;
  double offset = 0.0;
  bool complement = false;
  if (a > 1.0) {  // atan(a) = pi/2 - atan(1/a)
    a = 1.0 / a;
    complement = true;
  }
  constexpr double kTan15 = 0.26794919243112270647;  // tan(pi/12)
  constexpr double kSqrt3 = 1.73205080756887729353;
  if (a > kTan15) {  // atan(a) = pi/6 + atan((sqrt3 a - 1) / (sqrt3 + a))
    a = (kSqrt3 * a - 1.0) / (kSqrt3 + a);
    offset = kPi / 6.0;
  }
  double result = offset + detail::atan_reduced(a);
  if (complement) result = kHalfPi - result;
  return negative ? -result : result;
}

inline double atan2(double y, double x) {
  if (std::isnan(x) || std::isnan(y)) return x + y;
  if (x == 0.0 && y == 0.0) return std::signbit(x) ? (std::signbit(y) ? -kPi : kPi) : y;
  if (x == 0.0) return y > 0.0 ? kHalfPi : -kHalfPi;
  if (std::isinf(x) || std::isinf(y)) {
    // Rare; fall back to exact quadrant values.
    const double ax = std::isinf(x) ? 1.0 : 0.0, ay = std::isinf(y) ? 1.0 : 0.0;
    const double base = (ax > 0.0 && ay > 0.0) ? kPi / 4.0 : (ay > 0.0 ? kHalfPi : 0.0);
    const double q = x < 0.0 ? kPi - base : base;
    return y < 0.0 || (y == 0.0 && std::signbit(y)) ? -q : q;
  }
  const double a = atan(y / x);
  if (x > 0.0) return a;
  return y >= 0.0 ? a + kPi : a - kPi;
}

// acos/asin through atan2 with (1-x)(1+x) to keep precision near |x| = 1.
inline double acos(double x) {
  if (!(x >= -1.0 && x <= 1.0)) return std::nan("");
  return atan2(std::sqrt((1.0 - x) * (1.0 + x)), x);
}
inline double asin(double x) {
  if (!(x >= -1.0 && x <= 1.0)) return std::nan("");
  return atan2(x, std::sqrt((1.0 - x) * (1.0 + x)));
}

// Wraps an angle to (-pi, pi].
inline double wrap_pi(double a) {
  if (!std::isfinite(a)) return a;
  const double k = std::nearbyint(a * (1.0 / (2.0 * kPi)));
  double r = a - k * (2.0 * kPi);
  if (r <= -kPi) r += 2.0 * kPi;
  if (r > kPi) r -= 2.0 * kPi;
  return r;
}

// floor(x) as an integer for |x| < 2^31, without a libm call (std::floor is one on baseline
// x86-64 and many Cortex builds): truncate, then step down for negative non-integers. Exact.
inline std::int32_t floor_to_int(float x) {
  const auto t = static_cast<std::int32_t>(x);
  return t - (x < static_cast<float>(t) ? 1 : 0);
}
inline std::int32_t floor_to_int(double x) {
  const auto t = static_cast<std::int32_t>(x);
  return t - (x < static_cast<double>(t) ? 1 : 0);
}

}  // namespace v2xloc::det
