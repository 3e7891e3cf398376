// Common fixed-size types of the core. Points are stored as float (memory), every
// accumulation (covariances, normal equations, poses) is done in double.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>

namespace v2xloc {

using Vec3f = Eigen::Matrix<float, 3, 1>;
using Vec3d = Eigen::Matrix<double, 3, 1>;
using Vec6d = Eigen::Matrix<double, 6, 1>;
using Mat3d = Eigen::Matrix<double, 3, 3>;
using Mat4d = Eigen::Matrix<double, 4, 4>;
using Mat6d = Eigen::Matrix<double, 6, 6>;

inline constexpr int kFpfhBins = 33;  // 3 angle features x 11 bins (Rusu 2009, Open3D layout)
using Feature33 = Eigen::Matrix<float, kFpfhBins, 1>;

}  // namespace v2xloc
