// The body's roll and pitch for the tracking guess. The pose filter is a ground-plane filter
// (position and yaw); on a graded or crowned road the scan is tilted by the road's slope (a 5 %
// grade is 2.9 deg: 2.5 m at 50 m range), which a level guess leaves to the tracking ICP. The
// last converged registration's tilt (the ground constrains it even while the validity gate is
// undecided) is carried to the frame by the odometry's rotation since then, and the filter's yaw
// replaces the carried heading.
#pragma once

#include "v2xloc/algo/localization/pose_types.hpp"

namespace v2xloc {

class GroundAttitude {
 public:
  void reset() { known_ = false; }
  // A converged registration: world_T_body from it, odom_T_body the odometry at its frame.
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
