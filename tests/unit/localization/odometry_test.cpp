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
  odom.reset();
  std::vector<Vec3f> scan(10, Vec3f(NAN, 0.0f, 0.0f));
  const OdometryResult r = odom.register_frame(scan);
  EXPECT_EQ(r.status, OdometryStatus::kEmptyScan);
  EXPECT_EQ(r.points_dropped_range, 10u);
  EXPECT_TRUE(r.pose.matrix().allFinite());
}

TEST(LidarOdometry, MapEvictsVoxelsBeyondRange) {
  static LidarOdometry odom;
  OdometryParams p;
  p.voxel_size = 1.0;
  p.max_range = 20.0;
  odom.configure(p);
  std::vector<Vec3f> scan;
  for (int i = -15; i <= 15; ++i)
    for (int j = -15; j <= 15; ++j) scan.emplace_back(float(i), float(j), -1.5f);
  odom.reset();
  odom.register_frame(scan);
  const std::size_t before = odom.map_voxel_count();
  // Restart 100 m away: the first frame's voxels are all beyond max_range and must go.
  Mat4d far = Mat4d::Identity();
  far(0, 3) = 100.0;
  odom.reset(Pose3d(far));
  odom.register_frame(scan);
  EXPECT_GT(before, 0u);
  for (const MapPoint& m : odom.map_points()) EXPECT_GT(m.x, 80.0f);
}

}  // namespace
}  // namespace v2xloc
