#include "v2xloc/algo/localization/ground_attitude.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {

double road_grade_of(const Vec3d& forward) {
  return forward.z() / std::sqrt(forward.x() * forward.x() + forward.y() * forward.y());
}

void GroundAttitude::on_registration(const Pose3d& world_T_body, const Pose3d& odom_T_body) {
  if (!(world_T_body.linear()(2, 2) >= kMinUpCosine)) {
    known_ = false;
    return;
  }
  world_R_odom_ = world_T_body.linear() * odom_T_body.linear().transpose();
  known_ = true;
}

Pose3d GroundAttitude::tilt(const Pose3d& level, const Pose3d& odom_T_body) const {
  if (!known_) return level;
  const Mat3d carried = world_R_odom_ * odom_T_body.linear();
  if (carried(2, 2) > kLevelUpCosine) return level;
  // Carried = Rz(heading) * tilt: keep the tilt, take the heading from `level`.
  const double heading = det::atan2(carried(1, 0), carried(0, 0));
  Pose3d out = level;
  out.linear() = level.linear() * rot_z(heading).transpose() * carried;
  return out;
}

bool GroundAttitude::grade(const Pose3d& odom_T_body, double& out) const {
  if (!known_) return false;
  out = road_grade_of(world_R_odom_ * odom_T_body.linear().col(0));
  return true;
}

}  // namespace v2xloc
