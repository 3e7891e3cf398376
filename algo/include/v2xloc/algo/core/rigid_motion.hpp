// Rigid-motion helpers shared by deskewing, odometry and the EKF: SO(3)/SE(3) exponential and
// logarithm (Barfoot, "State Estimation for Robotics", 2017, eqs. 7.14, 7.37, 7.83-7.86) and
// yaw extraction, on det_math (same bits on every ISA). Twist order (vx, vy, vz, wx, wy, wz):
// translation first, rotation second. Poses are homogeneous Mat4d.
#pragma once

#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

Mat3d skew(const Vec3d& v);
// Rodrigues: rotation by |w| about w / |w| (series near 0).
Mat3d so3_exp(const Vec3d& w);
// Rodrigues in closed form down to |w|^2 = 1e-20, first order (I + [w]x) below: the ICP
// update's exponential. Not merged with so3_exp (Taylor below 1e-4 rad): the two round
// differently and the registration results are pinned to these bits (golden tests).
Mat3d so3_exp_closed_form(const Vec3d& w);
// Rotation vector of R, angle in [0, pi].
Vec3d so3_log(const Mat3d& R);
Mat4d se3_exp(const Vec6d& xi);
Vec6d se3_log(const Mat4d& T);
// Rigid inverse (R^T, -R^T t).
Mat4d se3_inverse(const Mat4d& T);
// A pose known at an earlier frame, carried to now by the odometry driven since (odom_then, odom_now:
// the odometry poses of the two frames).
inline Mat4d carried_by_odometry(const Mat4d& pose, const Mat4d& odom_then, const Mat4d& odom_now) {
  return pose * se3_inverse(odom_then) * odom_now;
}
// ZYX yaw of a rotation: atan2(R10, R00).
double yaw_of(const Mat3d& R);
// Rotation about +z.
Mat3d rot_z(double yaw);
// Re-orthonormalises a rotation drifting from repeated products (Gram-Schmidt on columns).
Mat3d orthonormalize(const Mat3d& R);

}  // namespace v2xloc
