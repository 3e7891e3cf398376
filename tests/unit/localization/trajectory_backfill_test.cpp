#include "v2xloc/algo/localization/trajectory_backfill.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {
namespace {

// A drive along a gentle left curve: truth world_T_body(k); the odometry frame is rotated and
// shifted against the world (as a LiDAR odometry's first-scan frame is).
Mat4d truth_pose(std::uint32_t k) {
  Vec6d xi = Vec6d::Zero();
  xi(0) = 0.6 * k;   // 6 m/s at 10 Hz
  xi(5) = 0.01 * k;  // slow turn
  Mat4d start = Mat4d::Identity();
  start.topLeftCorner<3, 3>() = rot_z(0.7);
  start(0, 3) = 40.0;
  start(1, 3) = -12.0;
  return start * se3_exp(xi);
}

Mat4d world_T_odom() {
  Mat4d t = Mat4d::Identity();
  t.topLeftCorner<3, 3>() = rot_z(-1.1);
  t(0, 3) = 5.0;
  t(1, 3) = 3.0;
  t(2, 3) = 1.8;
  return t;
}

BackfillSample frame_sample(std::uint32_t k, bool anchored, bool odometry_ok = true) {
  BackfillSample s;
  s.frame = k;
  s.odom_T_body = se3_inverse(world_T_odom()) * truth_pose(k);
  s.anchored = anchored;
  s.odometry_ok = odometry_ok;
  // Unanchored frames output a GNSS-like fix 12 m off; anchored ones the truth.
  s.world_T_body = truth_pose(k);
  if (!anchored) s.world_T_body(0, 3) += 12.0;
  return s;
}

double position_error(const Mat4d& a, const Mat4d& b) {
  return (a.topRightCorner<3, 1>() - b.topRightCorner<3, 1>()).norm();
}

TEST(TrajectoryBackfill, FilterStartRevisesStartUpFramesThroughTheOdometry) {
  TrajectoryBackfill backfill;
  for (std::uint32_t k = 0; k < 15; ++k) EXPECT_EQ(backfill.push(frame_sample(k, false)), 0u);
  EXPECT_EQ(backfill.push(frame_sample(15, true)), 15u);
  for (std::uint32_t k = 0; k <= 15; ++k) {
    Mat4d pose;
    bool revised = false;
    ASSERT_TRUE(backfill.pose(k, pose, revised)) << k;
    EXPECT_EQ(revised, k < 15) << k;
    EXPECT_LT(position_error(pose, truth_pose(k)), 1e-9) << k;
  }
  // Later anchored frames revise nothing.
  EXPECT_EQ(backfill.push(frame_sample(16, true)), 0u);
  EXPECT_EQ(backfill.counters().anchors, 1u);
  EXPECT_EQ(backfill.counters().revised_frames, 15u);
}

TEST(TrajectoryBackfill, OdometryBreakStopsTheRevision) {
  TrajectoryBackfill backfill;
  // Frame 6's odometry failed: frames 0..5 are not linked to the anchor at 10.
  for (std::uint32_t k = 0; k < 10; ++k) backfill.push(frame_sample(k, false, k != 6));
  EXPECT_EQ(backfill.push(frame_sample(10, true)), 4u);  // frames 6..9
  Mat4d pose;
  bool revised = true;
  ASSERT_TRUE(backfill.pose(5, pose, revised));
  EXPECT_FALSE(revised);
  EXPECT_NEAR(position_error(pose, truth_pose(5)), 12.0, 1e-9);  // still the live output
  ASSERT_TRUE(backfill.pose(6, pose, revised));
  EXPECT_TRUE(revised);
  EXPECT_LT(position_error(pose, truth_pose(6)), 1e-9);
  // An anchor whose own odometry failed cannot carry anything back.
  TrajectoryBackfill broken;
  for (std::uint32_t k = 0; k < 5; ++k) broken.push(frame_sample(k, false));
  EXPECT_EQ(broken.push(frame_sample(5, true, false)), 0u);
}

TEST(TrajectoryBackfill, TrackedFramesAreNeverRewrittenAfterALoss) {
  TrajectoryBackfill backfill;
  for (std::uint32_t k = 0; k < 5; ++k) backfill.push(frame_sample(k, true));
  for (std::uint32_t k = 5; k < 8; ++k) backfill.push(frame_sample(k, false));  // track lost
  BackfillSample restart = frame_sample(8, true);
  restart.world_T_body(1, 3) += 0.5;  // the restart is 0.5 m off: the revision inherits it
  EXPECT_EQ(backfill.push(restart), 3u);
  Mat4d pose;
  bool revised = false;
  ASSERT_TRUE(backfill.pose(4, pose, revised));
  EXPECT_FALSE(revised);
  EXPECT_LT(position_error(pose, truth_pose(4)), 1e-9);
  ASSERT_TRUE(backfill.pose(6, pose, revised));
  EXPECT_TRUE(revised);
  EXPECT_NEAR(position_error(pose, truth_pose(6)), 0.5, 1e-9);
}

TEST(TrajectoryBackfill, BoundedBufferCountsFramesThatLeftUnrevised) {
  TrajectoryBackfill backfill;
  const std::uint32_t n = static_cast<std::uint32_t>(TrajectoryBackfill::kCapacity) + 20;
  for (std::uint32_t k = 0; k < n; ++k) backfill.push(frame_sample(k, false));
  EXPECT_EQ(backfill.size(), TrajectoryBackfill::kCapacity);
  EXPECT_EQ(backfill.counters().unrevised_frames, 20u);
  Mat4d pose;
  bool revised = false;
  EXPECT_FALSE(backfill.pose(0, pose, revised));  // left the buffer: final as output
  EXPECT_FALSE(backfill.pose(n, pose, revised));  // not pushed yet
  // The anchor revises at most what the buffer holds.
  EXPECT_EQ(backfill.push(frame_sample(n, true)), TrajectoryBackfill::kCapacity - 1);
  backfill.reset();
  EXPECT_EQ(backfill.size(), 0u);
  EXPECT_EQ(backfill.counters().revised_frames, 0u);
}

}  // namespace
}  // namespace v2xloc
