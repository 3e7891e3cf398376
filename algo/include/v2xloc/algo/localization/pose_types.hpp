// What a 4x4 means in the localizer's interface. A rigid transform is a Pose3d (a_T_b maps
// points of frame b into frame a); the (x, y, z, yaw) covariance of a pose measurement is a
// PoseCovariance. The two are distinct types: one cannot be passed for the other.
// The arithmetic stays on the 4x4 matrix (pose.matrix()), exactly as before the names existed:
// a Pose3d only carries and labels the same 16 doubles.
#pragma once

#include <Eigen/Geometry>

#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

using Pose3d = Eigen::Transform<double, 3, Eigen::Isometry>;
using PoseCovariance = Eigen::Matrix<double, 4, 4>;  // (x, y, z, yaw), ekf.hpp's order

}  // namespace v2xloc
