#include "v2xloc/algo/localization/deskew.hpp"

#include <cmath>

#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {

DeskewResult deskew(std::span<const Vec3f> points, std::span<const float> times,
                    const Mat4d& delta, const DeskewParams& params, std::span<Vec3f> out) {
  DeskewResult r;
  if (times.size() != points.size() || !delta.allFinite() || !(params.delta_duration > 0.0) ||
      !std::isfinite(params.reference_time)) {
    return r;
  }
  const Vec6d twist = se3_log(delta) / params.delta_duration;  // [m/s, rad/s] in the sensor frame
  const Vec3d v = twist.head<3>(), w = twist.tail<3>();
  r.status = DeskewStatus::kOk;
  std::size_t n = 0;
  // exp(xi (t_i - t_ref)) p_i, exact for a constant twist. The exp is evaluated at an anchor
  // stamp; a point stamped within kSeriesSpan of it takes the rest of the motion, exp(xi d) with
  // d = t_i - t_anchor (the same one-parameter group: exp(xi a) exp(xi d) = exp(xi (a + d))), as
  // its series to second order, p + d u + d^2/2 w x u with u = w x p + v. A spinning LiDAR that
  // stamps each laser's firing gives almost every point its own stamp (a real 62k-point sweep:
  // 53k distinct, ~12 us apart): one exp per stamp was the scan's dearest step. The third-order
  // term, |w d|^3 / 6 of the range (1 rad/s, 40 us: 1e-14), is far below float resolution; points
  // sharing the anchor's stamp (a firing of all beams at one azimuth) take the exp alone.
  // The span scales with the rotation: the term is (|w| d)^3 / 6, so kSeriesSpan / |w| keeps it at
  // the 1 rad/s figure (a car turning at 0.2 rad/s: 200 us), up to kMaxSeriesSpan (the series is
  // exact for a pure translation).
  constexpr double kSeriesSpan = 40e-6;    // [s] at 1 rad/s: under one azimuth step of a 10 Hz, 2048-step sweep
  constexpr double kMaxSeriesSpan = 1e-3;  // [s]
  const double rate = w.norm();
  const double span = rate * kMaxSeriesSpan > kSeriesSpan ? kSeriesSpan / rate : kMaxSeriesSpan;
  Mat4d T = Mat4d::Identity();
  double t_of_T = 0.0;
  bool have_T = false;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points[i];
    const double ti = static_cast<double>(times[i]);
    if (!p.allFinite() || !std::isfinite(ti)) {
      ++r.non_finite_dropped;
      continue;
    }
    if (n == out.size()) {
      ++r.capacity_dropped;
      r.status = DeskewStatus::kTruncated;
      continue;
    }
    if (!have_T || !(std::abs(ti - t_of_T) < span)) {
      T = se3_exp(twist * (ti - params.reference_time));
      t_of_T = ti;
      have_T = true;
    }
    Vec3d pl = p.cast<double>();
    if (ti != t_of_T) {
      const double d = ti - t_of_T;
      const Vec3d u = w.cross(pl) + v;
      pl += d * u + (0.5 * d * d) * w.cross(u);
    }
    const Vec3d q = T.topLeftCorner<3, 3>() * pl + T.topRightCorner<3, 1>();
    out[n++] = q.cast<float>();
  }
  r.points_out = static_cast<std::uint32_t>(n);
  return r;
}

}  // namespace v2xloc
