// A confirmed start-up begins at the information-weighted mean of the confirming registration and
// the candidate it confirmed (PoseFilter::start_pose): equal registrations meet half-way, the
// better-constrained one pulls the start towards itself, a candidate without information (the
// basin audit's nomination) leaves the confirmation's pose as it is.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/pose_filter.hpp"

namespace v2xloc {
namespace {

// Open3D's information of a point-to-point fit on `n` target points on a ring of `radius` around
// the origin (registration_result.hpp): sum of J^T J, J = [-[q]x | I3].
Mat6d ring_information(int n, double radius) {
  Mat6d info = Mat6d::Zero();
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * 3.141592653589793 * i / n;
    const Vec3d q(radius * std::cos(a), radius * std::sin(a), 0.3 * ((i % 3) - 1));
    Eigen::Matrix<double, 3, 6> J;
    J.block<3, 3>(0, 0) = -skew(q);
    J.block<3, 3>(0, 3) = Mat3d::Identity();
    info += J.transpose() * J;
  }
  return info;
}

Mat3d about(const Vec3d& axis, double angle) { return Eigen::AngleAxisd(angle, axis).toRotationMatrix(); }

RegistrationResult registration_at(double x, double y, double yaw, double rmse, const Mat6d& info) {
  RegistrationResult r;
  r.status = RegistrationStatus::kOk;
  r.transform.topLeftCorner<3, 3>() = rot_z(yaw);
  r.transform(0, 3) = x;
  r.transform(1, 3) = y;
  r.inlier_rmse = rmse;
  r.information = info;
  return r;
}

std::unique_ptr<PoseFilter> configured_filter() {
  auto filter = std::make_unique<PoseFilter>();
  filter->configure(PoseFilterParams{}, true);
  return filter;
}

TEST(StartPose, EqualRegistrationsMeetHalfWay) {
  const auto filter = configured_filter();
  const Mat6d info = ring_information(20, 3.0);
  const RegistrationResult confirmation = registration_at(0.04, -0.02, 0.010, 0.05, info);
  const RegistrationResult candidate = registration_at(0.00, 0.02, 0.004, 0.05, info);
  const Mat4d start = filter->start_pose(confirmation, candidate).matrix();
  // Half-way up to the small coupling of yaw into position at the two (different) vehicle positions.
  EXPECT_NEAR(start(0, 3), 0.02, 5e-4);
  EXPECT_NEAR(start(1, 3), 0.00, 5e-4);
  EXPECT_NEAR(yaw_of(start.topLeftCorner<3, 3>()), 0.007, 1e-4);
}

TEST(StartPose, TheBetterConstrainedRegistrationPullsTheStart) {
  const auto filter = configured_filter();
  const Mat6d info = ring_information(20, 3.0);
  const RegistrationResult confirmation = registration_at(0.10, 0.0, 0.02, 0.08, info);
  const RegistrationResult candidate = registration_at(0.00, 0.0, 0.00, 0.02, info);  // 16x the information
  const Mat4d start = filter->start_pose(confirmation, candidate).matrix();
  EXPECT_GT(start(0, 3), 0.0);
  EXPECT_LT(start(0, 3), 0.02);  // 1/17 of the way from the candidate when no floor binds
  const double yaw = yaw_of(start.topLeftCorner<3, 3>());
  EXPECT_GT(yaw, 0.0);
  EXPECT_LT(yaw, 0.004);
  // Neither role weighs more than its information: swapped, the same start.
  const Mat4d swapped = filter->start_pose(candidate, confirmation).matrix();
  EXPECT_NEAR(swapped(0, 3), start(0, 3), 1e-9);
  EXPECT_NEAR(yaw_of(swapped.topLeftCorner<3, 3>()), yaw, 1e-9);
}

TEST(StartPose, ACandidateWithoutInformationLeavesTheConfirmation) {
  const auto filter = configured_filter();
  RegistrationResult confirmation = registration_at(5.0, 7.0, 1.2, 0.03, ring_information(20, 3.0));
  confirmation.transform.topLeftCorner<3, 3>() = rot_z(1.2) * about(Vec3d::UnitX(), 0.01) * about(Vec3d::UnitY(), -0.02);  // roll and pitch kept
  const RegistrationResult nominated = registration_at(5.1, 7.0, 1.21, 0.0, Mat6d::Zero());
  EXPECT_EQ(filter->start_pose(confirmation, nominated).matrix(), confirmation.transform);
  RegistrationResult none;  // no candidate at all
  EXPECT_EQ(filter->start_pose(confirmation, none).matrix(), confirmation.transform);
}

TEST(StartPose, RollAndPitchAreTheConfirmations) {
  const auto filter = configured_filter();
  const Mat6d info = ring_information(20, 3.0);
  RegistrationResult confirmation = registration_at(0.0, 0.0, 0.5, 0.05, info);
  confirmation.transform.topLeftCorner<3, 3>() = rot_z(0.5) * about(Vec3d::UnitY(), 0.03);
  const RegistrationResult candidate = registration_at(0.0, 0.0, 0.51, 0.05, info);
  const Mat4d start = filter->start_pose(confirmation, candidate).matrix();
  const Mat3d turned = rot_z(-0.005) * start.topLeftCorner<3, 3>();  // undo the half-way yaw step
  EXPECT_TRUE(turned.isApprox(confirmation.transform.topLeftCorner<3, 3>(), 1e-9));
}

}  // namespace
}  // namespace v2xloc
