#include "v2xloc/algo/core/rigid_motion.hpp"

#include <gtest/gtest.h>

namespace v2xloc {
namespace {

TEST(RigidMotion, ExpLogRoundTrip) {
  const Vec6d cases[] = {
      (Vec6d() << 1.0, -2.0, 0.5, 0.1, -0.2, 0.3).finished(),
      (Vec6d() << 0.3, 0.0, 0.0, 0.0, 0.0, 1e-7).finished(),
      (Vec6d() << 0.0, 1.0, 0.0, 0.0, 0.0, 3.1).finished(),
      Vec6d::Zero()};
  for (const Vec6d& xi : cases) {
    const Mat4d T = se3_exp(xi);
    EXPECT_NEAR((T.topLeftCorner<3, 3>().transpose() * T.topLeftCorner<3, 3>() -
                 Mat3d::Identity()).norm(), 0.0, 1e-12);
    EXPECT_NEAR((se3_log(T) - xi).norm(), 0.0, 1e-9);
  }
  const Mat4d T = se3_exp(cases[0]);
  EXPECT_NEAR((se3_inverse(T) * T - Mat4d::Identity()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(yaw_of(rot_z(2.5)), 2.5, 1e-14);
}

}  // namespace
}  // namespace v2xloc
