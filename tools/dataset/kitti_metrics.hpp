// KITTI odometry metrics, by the benchmark's definition (Geiger et al., CVPR 2012, and the
// odometry devkit): for every start frame (every `step` frames) and every length L, the segment
// runs to the first frame whose ground-truth path distance from the start exceeds L. The
// segment's error is E = (T_est(a)^-1 T_est(b))^-1 (T_gt(a)^-1 T_gt(b)); translational error
// |t(E)| / L, rotational error angle(R(E)) / L. The benchmark averages over all segments of
// L = 100, 200, ..., 800 m with step 10 and reports % and deg/100 m.
// Sequences too short for a 100 m segment (test fixtures, short drives) use scaled lengths
// 10 %, 20 %, ..., 80 % of the path length with step 1, and say so (length_set "scaled").
#pragma once

#include "v2xloc/algo/core/types.hpp"

#include <string>
#include <vector>

namespace v2xloc::dataset {

struct KittiLengthError {
  double length_m = 0.0;
  std::size_t segments = 0;
  double translation_pct = 0.0;
  double rotation_deg_per_100m = 0.0;
};

struct KittiMetrics {
  std::string length_set;           // "kitti" (100..800 m) or "scaled" (10..80 % of the path)
  int step = 10;                    // frames between segment starts
  double path_length_m = 0.0;       // ground truth
  std::size_t segments = 0;         // all lengths
  double translation_pct = 0.0;     // mean over all segments
  double rotation_deg_per_100m = 0.0;
  std::vector<KittiLengthError> per_length;  // lengths with >= 1 segment
};

// gt and estimate: the same number of poses, same frame convention. Metrics of zero segments
// (a single frame, no motion) have segments == 0 and zero errors.
KittiMetrics kitti_odometry_metrics(const std::vector<Mat4d>& gt, const std::vector<Mat4d>& estimate);

}  // namespace v2xloc::dataset
