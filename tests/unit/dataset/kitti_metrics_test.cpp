// The KITTI odometry metric against hand-computed values (definition: Geiger et al. 2012 and the
// benchmark devkit; see tools/dataset/kitti_metrics.hpp).
#include "tools/dataset/kitti_metrics.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc::dataset {
namespace {

// Straight drive along z (KITTI's camera forward axis), 1 m per frame.
std::vector<Mat4d> straight(int frames, double step_m) {
  std::vector<Mat4d> poses;
  for (int i = 0; i < frames; ++i) {
    Mat4d p = Mat4d::Identity();
    p(2, 3) = step_m * i;
    poses.push_back(p);
  }
  return poses;
}

TEST(KittiMetrics, PerfectEstimateHasZeroError) {
  const std::vector<Mat4d> gt = straight(300, 1.0);
  const KittiMetrics m = kitti_odometry_metrics(gt, gt);
  EXPECT_EQ(m.length_set, "kitti");
  EXPECT_GT(m.segments, 0u);
  EXPECT_NEAR(m.translation_pct, 0.0, 1e-12);
  EXPECT_NEAR(m.rotation_deg_per_100m, 0.0, 1e-12);
}

// An estimate that travels 2 % too far has 2 % translational error on every segment.
TEST(KittiMetrics, ScaleErrorGivesThatPercentage) {
  const std::vector<Mat4d> gt = straight(300, 1.0);
  const std::vector<Mat4d> est = straight(300, 1.02);
  const KittiMetrics m = kitti_odometry_metrics(gt, est);
  ASSERT_EQ(m.length_set, "kitti");
  EXPECT_EQ(m.step, 10);
  // Path 299 m: lengths 100 and 200 fit. Segment (first, first + L + 1): the devkit's first
  // frame strictly beyond L, so the error is 2 % of L + 1 over L.
  ASSERT_EQ(m.per_length.size(), 2u);
  EXPECT_DOUBLE_EQ(m.per_length[0].length_m, 100.0);
  // starts 0, 10, ..., 190 reach frame first + 101 <= 299 (20 starts); 200 m: starts 0..90 (10).
  EXPECT_EQ(m.per_length[0].segments, 20u);
  EXPECT_EQ(m.per_length[1].segments, 10u);
  EXPECT_NEAR(m.per_length[0].translation_pct, 2.0 * 101.0 / 100.0, 1e-9);
  EXPECT_NEAR(m.per_length[1].translation_pct, 2.0 * 201.0 / 200.0, 1e-9);
  EXPECT_NEAR(m.rotation_deg_per_100m, 0.0, 1e-9);
}

// A constant yaw-rate error: rotational error in deg/100 m equals the heading drift per 100 m.
TEST(KittiMetrics, HeadingDriftGivesDegreesPer100m) {
  const std::vector<Mat4d> gt = straight(250, 1.0);
  std::vector<Mat4d> est = gt;
  const double drift_deg_per_m = 0.01;  // 1 deg / 100 m
  for (std::size_t i = 0; i < est.size(); ++i) {
    Mat3d r = Mat3d::Identity();
    r = Eigen::AngleAxisd(drift_deg_per_m * M_PI / 180.0 * static_cast<double>(i), Vec3d::UnitY());
    est[i].topLeftCorner<3, 3>() = r;
  }
  const KittiMetrics m = kitti_odometry_metrics(gt, est);
  ASSERT_EQ(m.per_length.size(), 2u);
  EXPECT_NEAR(m.per_length[0].rotation_deg_per_100m, 1.01, 1e-6);  // 101 frames per 100 m segment
}

// A 30 m drive has no 100 m segment: the scaled lengths (10..80 % of the path) are used.
TEST(KittiMetrics, ShortSequenceUsesScaledLengths) {
  const std::vector<Mat4d> gt = straight(31, 1.0);
  const KittiMetrics m = kitti_odometry_metrics(gt, straight(31, 1.05));
  EXPECT_EQ(m.length_set, "scaled");
  EXPECT_EQ(m.step, 1);
  EXPECT_DOUBLE_EQ(m.path_length_m, 30.0);
  ASSERT_FALSE(m.per_length.empty());
  EXPECT_DOUBLE_EQ(m.per_length[0].length_m, 3.0);
  EXPECT_GT(m.segments, 50u);
  EXPECT_GT(m.translation_pct, 5.0);
  EXPECT_LT(m.translation_pct, 5.0 * 2.0);
}

TEST(KittiMetrics, SingleFrameHasNoSegments) {
  const KittiMetrics m = kitti_odometry_metrics(straight(1, 1.0), straight(1, 1.0));
  EXPECT_EQ(m.segments, 0u);
  EXPECT_TRUE(m.per_length.empty());
}

}  // namespace
}  // namespace v2xloc::dataset
