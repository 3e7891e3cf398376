// LiDAR odometry: degenerate inputs and map eviction (the corridor drive is in
// odometry_corridor_test.cpp, label slow).
#include "v2xloc/algo/localization/odometry.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <random>
#include <vector>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {
namespace {

TEST(LidarOdometry, EmptyAndNonFiniteScansAreHandled) {
  static LidarOdometry odom;
  static OdometryScanBuffers buffers;
  odom.reset();
  std::vector<Vec3f> scan(10, Vec3f(NAN, 0.0f, 0.0f));
  const OdometryResult r = odom.register_frame(scan, buffers);
  EXPECT_EQ(r.status, OdometryStatus::kEmptyScan);
  EXPECT_EQ(r.points_dropped_range, 10u);
  EXPECT_TRUE(r.pose.matrix().allFinite());
}

TEST(LidarOdometry, MapEvictsVoxelsBeyondRange) {
  static LidarOdometry odom;
  static OdometryScanBuffers buffers;
  OdometryParams p;
  p.voxel_size = 1.0;
  p.max_range = 20.0;
  odom.configure(p);
  std::vector<Vec3f> scan;
  for (int i = -15; i <= 15; ++i)
    for (int j = -15; j <= 15; ++j) scan.emplace_back(float(i), float(j), -1.5f);
  odom.reset();
  odom.register_frame(scan, buffers);
  const std::size_t before = odom.map_voxel_count();
  // Restart 100 m away: the first frame's voxels are all beyond max_range and must go.
  Mat4d far = Mat4d::Identity();
  far(0, 3) = 100.0;
  odom.reset(Pose3d(far));
  odom.register_frame(scan, buffers);
  EXPECT_GT(before, 0u);
  for (const MapPoint& m : odom.map_points()) EXPECT_GT(m.x, 80.0f);
}

// A pre-voxelised frame keeps every fine_decimation-th point, then at most max_fine_points of
// those (evenly): both thinnings are reported, the cap's separately (the localizer counts it).
TEST(LidarOdometry, VoxelizedFrameThinning) {
  static LidarOdometry odom;
  std::vector<Vec3f> fine;
  for (int i = -20; i < 20; ++i)
    for (int j = -20; j < 20; ++j) fine.emplace_back(0.25f * i + 0.1f, 0.25f * j + 0.1f, -1.5f);  // 1,600 points
  OdometryParams p;
  p.fine_decimation = 2;
  odom.configure(p);
  odom.reset();
  OdometryResult r = odom.register_voxelized_frame(fine);
  EXPECT_EQ(r.fine_points_skipped, 800u);
  EXPECT_FALSE(r.fine_points_capped);
  EXPECT_EQ(r.status, OdometryStatus::kFirstFrame);
  p.max_fine_points = 500;  // 800 after decimation > 500: every 4th point of the frame
  odom.configure(p);
  odom.reset();
  r = odom.register_voxelized_frame(fine);
  EXPECT_EQ(r.fine_points_skipped, 1200u);
  EXPECT_TRUE(r.fine_points_capped);
  p.fine_decimation = 1;
  p.max_fine_points = 0;
  odom.configure(p);
  odom.reset();
  r = odom.register_voxelized_frame(fine);
  EXPECT_EQ(r.fine_points_skipped, 0u);
  EXPECT_FALSE(r.fine_points_capped);
}

}  // namespace
}  // namespace v2xloc
