// A start-up answer restarts a running filter only inside the filter's belief
// (PoseFilter::accepts_restart_at): a look-alike far away or turned around is refused, a cold
// start is never gated.
#include <gtest/gtest.h>

#include <memory>

#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/pose_filter.hpp"

namespace v2xloc {
namespace {

Pose3d pose_at(double x, double y, double yaw) {
  Mat4d m = Mat4d::Identity();
  m.topLeftCorner<3, 3>() = rot_z(yaw);
  m(0, 3) = x;
  m(1, 3) = y;
  return Pose3d(m);
}

TEST(ReacquisitionGate, AColdStartIsNotGated) {
  auto filter = std::make_unique<PoseFilter>();
  filter->configure(PoseFilterParams{}, true);
  EXPECT_TRUE(filter->accepts_restart_at(pose_at(1e4, -1e4, 3.0)));
}

TEST(ReacquisitionGate, ARunningFilterRefusesALookAlikeAndTakesANearbyAnswer) {
  auto filter = std::make_unique<PoseFilter>();
  const PoseFilterParams params;
  filter->configure(params, true);
  filter->start(10.0, pose_at(50.0, -20.0, 0.4), VehicleMotion{true, 6.0, 0.0});
  ASSERT_TRUE(filter->initialized());
  const double reach = params.reacquire_gate_sigmas * filter->sigma_xy() + params.reacquire_margin;
  EXPECT_TRUE(filter->accepts_restart_at(pose_at(50.0 + 0.9 * reach, -20.0, 0.4)));
  EXPECT_FALSE(filter->accepts_restart_at(pose_at(50.0 + 1.1 * reach, -20.0, 0.4)));
  EXPECT_FALSE(filter->accepts_restart_at(pose_at(-84.0, -20.0, 0.4 + 3.13)));  // the far side, turned around
  EXPECT_FALSE(filter->accepts_restart_at(pose_at(50.0, -20.0, 0.4 + 0.5)));    // in place, 29 deg off
  EXPECT_TRUE(filter->accepts_restart_at(pose_at(50.0, -20.0, 0.4 + 0.05)));
  filter->lose_track();  // the divergence monitor's reset: the next start is a cold one again
  EXPECT_TRUE(filter->accepts_restart_at(pose_at(-84.0, -20.0, 3.5)));
}

}  // namespace
}  // namespace v2xloc
