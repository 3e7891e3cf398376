#include "tools/dataset/kitti_metrics.hpp"

#include "tools/dataset/dataset_common.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"

#include <cmath>

namespace v2xloc::dataset {
namespace {

struct SegmentSums {
  std::size_t n = 0;
  double t = 0.0, r = 0.0;  // sums of |t|/L [-] and angle/L [rad/m]
};

// Segments of length L starting every `step` frames; adds each segment's errors to `sums`.
void add_segments(const std::vector<Mat4d>& gt, const std::vector<Mat4d>& est,
                  const std::vector<double>& dist, double length, int step, SegmentSums& sums) {
  const std::size_t n = gt.size();
  for (std::size_t first = 0; first < n; first += static_cast<std::size_t>(step)) {
    std::size_t last = first;
    while (last < n && dist[last] <= dist[first] + length) ++last;
    if (last >= n) continue;  // the sequence ends before the segment does
    const Mat4d delta_gt = se3_inverse(gt[first]) * gt[last];
    const Mat4d delta_est = se3_inverse(est[first]) * est[last];
    const Mat4d error = se3_inverse(delta_est) * delta_gt;
    sums.n += 1;
    sums.t += error.topRightCorner<3, 1>().norm() / length;
    sums.r += rotation_angle_rad(error.topLeftCorner<3, 3>()) / length;
  }
}

}  // namespace

KittiMetrics kitti_odometry_metrics(const std::vector<Mat4d>& gt, const std::vector<Mat4d>& estimate) {
  KittiMetrics m;
  const std::size_t n = gt.size() < estimate.size() ? gt.size() : estimate.size();
  std::vector<double> dist(n, 0.0);
  for (std::size_t i = 1; i < n; ++i)
    dist[i] = dist[i - 1] + (gt[i].topRightCorner<3, 1>() - gt[i - 1].topRightCorner<3, 1>()).norm();
  m.path_length_m = n ? dist[n - 1] : 0.0;
  const std::vector<Mat4d> g(gt.begin(), gt.begin() + static_cast<std::ptrdiff_t>(n));
  const std::vector<Mat4d> e(estimate.begin(), estimate.begin() + static_cast<std::ptrdiff_t>(n));

  std::vector<double> lengths;
  // A 100 m segment needs a path longer than 100 m (the devkit's strict '>').
  if (m.path_length_m > 100.0) {
    m.length_set = "kitti";
    m.step = 10;
    for (int k = 1; k <= 8; ++k) lengths.push_back(100.0 * k);
  } else {
    m.length_set = "scaled";
    m.step = 1;
    for (int k = 1; k <= 8; ++k) lengths.push_back(m.path_length_m * 0.1 * k);
  }
  SegmentSums all;
  for (double length : lengths) {
    if (!(length > 0.0)) continue;
    SegmentSums s;
    add_segments(g, e, dist, length, m.step, s);
    if (s.n == 0) continue;
    KittiLengthError le;
    le.length_m = length;
    le.segments = s.n;
    le.translation_pct = 100.0 * s.t / static_cast<double>(s.n);
    le.rotation_deg_per_100m = 100.0 * (180.0 / M_PI) * s.r / static_cast<double>(s.n);
    m.per_length.push_back(le);
    all.n += s.n;
    all.t += s.t;
    all.r += s.r;
  }
  m.segments = all.n;
  if (all.n) {
    m.translation_pct = 100.0 * all.t / static_cast<double>(all.n);
    m.rotation_deg_per_100m = 100.0 * (180.0 / M_PI) * all.r / static_cast<double>(all.n);
  }
  return m;
}

}  // namespace v2xloc::dataset
