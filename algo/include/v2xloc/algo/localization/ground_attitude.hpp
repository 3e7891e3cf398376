// The body's roll and pitch for the tracking guess. The pose filter is a ground-plane filter
// (position and yaw); on a graded or crowned road the scan is tilted by the road's slope (a 5 %
// grade is 2.9 deg: 2.5 m at 50 m range), which a level guess leaves to the tracking ICP. The
// last converged registration's tilt (the ground constrains it even while the validity gate is
// undecided) is carried to the frame by the odometry's rotation since then, and the filter's yaw
// replaces the carried heading.
#pragma once

#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/localization/pose_types.hpp"

namespace v2xloc {

// A registration tilted more than this (0.15 rad, 8.6 deg: steeper than a 15 % street with its
// crown) did not find a road vehicle's attitude (a degenerate scan: one plane, one line, noise);
// its tilt would only misguide the next frames' ICP, so the attitude is forgotten instead.
inline constexpr double kMinUpCosine = 0.98877;  // cos(0.15)
// A carried tilt under 0.5 deg (a 0.9 % slope) is within the registrations' own scatter on level
// ground: the guess stays level, as the tracking ICP's work on a degenerate scan depends on it.
inline constexpr double kLevelUpCosine = 0.99996;  // cos(0.5 deg)

// The rise per metre driven along a body x axis (world frame): a road's grade from a pose's pitch.
// sqrt, not hypot: libms round hypot differently (the target must give the host's bits).
double road_grade_of(const Vec3d& forward);

class GroundAttitude {
 public:
  void reset() { known_ = false; }
  // A converged registration: world_T_body from it, odom_T_body the odometry at its frame (an
  // implausible tilt resets the attitude to unknown).
  void on_registration(const Pose3d& world_T_body, const Pose3d& odom_T_body);
  // `level` (the filter's pose, roll = pitch = 0) tilted by the carried attitude; level itself
  // before any fused registration.
  Pose3d tilt(const Pose3d& level, const Pose3d& odom_T_body) const;
  // The carried body x axis's rise per metre (the road's grade along the heading); false while unknown.
  bool grade(const Pose3d& odom_T_body, double& out) const;

 private:
  bool known_ = false;
  Mat3d world_R_odom_ = Mat3d::Identity();  // the registration's rotation less the odometry's
};

}  // namespace v2xloc
