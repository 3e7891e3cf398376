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
  r.status = DeskewStatus::kOk;
  std::size_t n = 0;
  // A spinning LiDAR fires its beams of one azimuth step at the same time stamp: the exp of the
  // previous point is reused when the time repeats (same value, computed once per firing).
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
    // One exp per point: exact for a constant twist (rotation and translation coupled).
    if (!have_T || ti != t_of_T) {
      T = se3_exp(twist * (ti - params.reference_time));
      t_of_T = ti;
      have_T = true;
    }
    const Vec3d q = T.topLeftCorner<3, 3>() * p.cast<double>() + T.topRightCorner<3, 1>();
    out[n++] = q.cast<float>();
  }
  r.points_out = static_cast<std::uint32_t>(n);
  return r;
}

}  // namespace v2xloc
