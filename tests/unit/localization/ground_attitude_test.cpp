// On a graded, crowned road: the tracking guess takes the last registration's roll and pitch,
// carried by the odometry (ground_attitude.hpp), and the filter climbs at the road's grade
// (EKF state 10, ekf.hpp) measured from that pitch.
#include "v2xloc/algo/localization/ground_attitude.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/ekf.hpp"

namespace v2xloc {
namespace {

namespace idx = ekf_index;

Mat3d rot_y(double a) { return Eigen::AngleAxisd(a, Vec3d::UnitY()).toRotationMatrix(); }
Mat3d rot_x(double a) { return Eigen::AngleAxisd(a, Vec3d::UnitX()).toRotationMatrix(); }

Pose3d pose(const Mat3d& r, const Vec3d& t) {
  Pose3d p = Pose3d::Identity();
  p.linear() = r;
  p.translation() = t;
  return p;
}

TEST(GroundAttitude, LevelUntilARegistrationThenItsTiltUnderTheFiltersHeading) {
  GroundAttitude attitude;
  const Pose3d level = pose(rot_z(0.7), Vec3d(5.0, 6.0, 1.0));
  const Pose3d odom_at_reg = pose(rot_z(0.1), Vec3d(2.0, 0.0, 0.0));
  EXPECT_TRUE(attitude.tilt(level, odom_at_reg).isApprox(level));
  double grade = 1.0;
  EXPECT_FALSE(attitude.grade(odom_at_reg, grade));

  const double pitch = -0.05, roll = 0.02;  // nose up (rotation about y pitches x down), rolled left
  attitude.on_registration(pose(rot_z(0.4) * rot_y(pitch) * rot_x(roll), Vec3d(1, 2, 3)), odom_at_reg);
  const Pose3d tilted = attitude.tilt(level, odom_at_reg);
  EXPECT_TRUE(tilted.linear().isApprox(rot_z(0.7) * rot_y(pitch) * rot_x(roll), 1e-12));
  EXPECT_TRUE(tilted.translation().isApprox(level.translation()));
  ASSERT_TRUE(attitude.grade(odom_at_reg, grade));
  EXPECT_NEAR(grade, std::tan(-pitch), 1e-12);

  // The odometry pitches the body further nose up by 0.01 rad: carried into the guess.
  const Pose3d odom_later = pose(odom_at_reg.linear() * rot_y(-0.01), Vec3d(8.0, 0.0, 0.3));
  ASSERT_TRUE(attitude.grade(odom_later, grade));
  EXPECT_NEAR(grade, std::tan(0.06), 1e-3);  // the roll tilts the pitch axis a little

  attitude.reset();
  EXPECT_TRUE(attitude.tilt(level, odom_later).isApprox(level));

  // A tilt within the registrations' scatter on level ground (0.2 deg) leaves the guess level.
  attitude.on_registration(pose(rot_y(0.0035), Vec3d::Zero()), odom_at_reg);
  EXPECT_TRUE(attitude.tilt(level, odom_at_reg).isApprox(level));
}

TEST(GroundAttitude, AnImplausibleTiltIsForgottenNotCarried) {
  GroundAttitude attitude;
  const Pose3d odom = Pose3d::Identity();
  attitude.on_registration(pose(rot_y(-0.05), Vec3d::Zero()), odom);
  double grade = 0.0;
  ASSERT_TRUE(attitude.grade(odom, grade));
  attitude.on_registration(pose(rot_x(0.4), Vec3d::Zero()), odom);  // 23 deg of roll: no road
  EXPECT_FALSE(attitude.grade(odom, grade));
  const Pose3d level = pose(rot_z(1.0), Vec3d(1, 2, 3));
  EXPECT_TRUE(attitude.tilt(level, odom).isApprox(level));
}

EkfState driving(double grade) {
  EkfState s;
  s.speed = 6.0;
  s.road_grade = grade;
  return s;
}

EkfCovariance tight(double grade_sigma) {
  EkfVector sd;
  sd << 0.1, 0.1, 0.1, 0.01, 0.05, 0.01, 0.005, 0.02, 0.01, 0.005, grade_sigma, 0.01, 0.1, 0.1;
  return sd.cwiseProduct(sd).asDiagonal();
}

TEST(EkfRoadGrade, TheFilterClimbsAtTheGrade) {
  const auto ekf = std::make_unique<Ekf>(EkfParams{});  // ~130 kB: not on the stack
  ekf->initialize(0.0, driving(0.05), tight(0.001));
  ekf->predict_to(2.0);
  EXPECT_NEAR(ekf->state().pos_z, 2.0 * 6.0 * 0.05, 1e-9);  // 12 m driven on a 5 % street
  EXPECT_NEAR(ekf->state().pos_x, 12.0, 1e-9);
}

TEST(EkfRoadGrade, GradeMeasurementsTeachTheGradeAndTheClimb) {
  const auto ekf = std::make_unique<Ekf>(EkfParams{});
  ekf->initialize(0.0, driving(0.0), tight(0.05));
  for (int k = 1; k <= 20; ++k) {
    ASSERT_EQ(ekf->on_road_grade(0.1 * k, 0.05, 0.005), EkfFuseStatus::kFused);
    ekf->predict_to(0.1 * k);
  }
  EXPECT_NEAR(ekf->state().road_grade, 0.05, 0.002);
  EXPECT_GT(ekf->state().pos_z, 0.5);  // climbed most of the 0.6 m of the last 2 s
  EXPECT_EQ(ekf->counters().grade_fused, 20u);
}

}  // namespace
}  // namespace v2xloc
