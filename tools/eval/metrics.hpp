// The paper's Table 1 columns from per-frame records. Every column is the mean Euclidean
// distance (3-D) between estimated and true body positions over the frames it covers:
//   slam        odometry, anchored at the true pose of frame 0 (drift only)
//   gps         latest GNSS fix (lever arm removed), frames with a fix: HORIZONTAL error, the
//               8-17 m the paper quotes (gps_3d adds the receiver's larger vertical error)
//   reg         registration pose, frames whose registration returned ok
//   reg_valid   registration pose, frames the fixed-lag validity gate accepted
//   fused       gated EKF, every frame (before the first fix of the filter: the GNSS fix)
//   fused_valid gated EKF, frames the validity gate accepted
//   fused_lag   fused, every frame, as revised within the backfill lag (start-up frames carried
//               back from the filter's first pose by the odometry; trajectory_backfill.hpp)
// Aligned = the same after an SE(3) Umeyama alignment of the estimate onto the truth per column
// (evo's APE --align, as the paper); unaligned is what the vehicle lives with.
#pragma once

#include <vector>

#include "tools/eval/offline_run.hpp"

namespace v2xloc::eval {

struct ColumnErrors {
  double slam = 0, gps = 0, reg = 0, reg_valid = 0, fused = 0, fused_valid = 0;
  double fused_ungated = 0;  // extra: EKF fed every ok registration (no envelope gate)
  double fused_lag = 0;      // extra: fused after the backfill's revisions (not live)
  double gps_3d = 0;         // extra: GNSS 3-D error
};

// Relative pose error over a time step (position differences: the drift a consumer sees between
// two outputs dt apart, independent of any constant offset), mean over every frame pair dt apart.
struct RelativeErrors {
  double fused = -1, slam = -1, gps = -1;  // [m], -1: no pair
};

// The constant offset the valid registrations imply between the map's frame and the truth's
// (registration - truth; on real data the sensors' cooperative calibration error): mean and
// spread (RMS deviation from the mean) of the position and yaw differences.
struct OffsetEstimate {
  int frames = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();  // [m]
  double spread = 0.0;                             // [m]
  double yaw_mean_deg = 0.0, yaw_spread_deg = 0.0;
  bool has_yaw = true;  // false where the registration's rotation is not known (the firmware's CAN)
};

struct RowMetrics {
  int frames = 0;            // frames the columns cover
  int frames_before_map = 0; // frames before the first map cloud (not in the columns)
  int valid_frames = 0;
  int reg_ok_frames = 0;
  ColumnErrors unaligned;
  ColumnErrors aligned;
  double fused_max = 0.0;   // unaligned worst frame of the gated EKF
  int revised_frames = 0;   // frames the backfill revised
  int first_localized_frame = -1;  // first frame flagged localized (-1: none; index into all frames)
  int first_initialized_frame = -1;  // first frame the filter ran (output not the GNSS fix)
  RelativeErrors rpe_1s;    // over 1 s
  OffsetEstimate offset;
};

// The columns cover the frames stamped at or after `map_from` (the first map cloud's stamp: before
// it nothing can be localized and the output is the GNSS fix); those before are counted in
// frames_before_map. The 12 simulated recordings share clouds from t = 0.
RowMetrics compute_metrics(const std::vector<FrameRecord>& records, double map_from = 0.0);

// Per-frame unaligned error of the gated EKF (plots).
std::vector<double> fused_errors(const std::vector<FrameRecord>& records);

}  // namespace v2xloc::eval
