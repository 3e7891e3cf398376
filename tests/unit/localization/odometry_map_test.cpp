// The odometry's voxel map: its pruned nearest-neighbour query returns bit for bit what the
// plain scan of the 2 x 2 x 2 voxels (the odometry's search before the pruning) returns, and the
// incremental index finds every voxel after updates with and without evictions.
#include "v2xloc/algo/localization/odometry_map.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <vector>

#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {
namespace {

// The search as the odometry ran it before the bounding boxes: every point of every visited
// voxel, distance by Eigen's squaredNorm.
bool reference_nearest(const OdometryVoxelMap& map, double voxel, const Vec3d& p, double max_d2, Vec3d& q,
                       double& d2) {
  std::int32_t key[3];
  if (!map.voxel_key(p, key)) return false;
  std::int32_t side[3];
  double gap2[3];
  for (int a = 0; a < 3; ++a) {
    const double frac = p(a) / voxel - key[a];
    side[a] = frac < 0.5 ? -1 : 1;
    const double gap = (side[a] < 0 ? frac : 1.0 - frac) * voxel;
    gap2[a] = gap * gap;
  }
  bool found = false;
  d2 = max_d2;
  static constexpr int kCornerOrder[8] = {0, 1, 2, 4, 3, 5, 6, 7};
  for (const int corner : kCornerOrder) {
    double box2 = 0.0;
    for (int a = 0; a < 3; ++a) box2 += (corner & (1 << a)) ? gap2[a] : 0.0;
    if (box2 * 0.999 >= d2) continue;
    const std::int32_t k[3] = {key[0] + ((corner & 1) ? side[0] : 0), key[1] + ((corner & 2) ? side[1] : 0),
                               key[2] + ((corner & 4) ? side[2] : 0)};
    for (const MapPoint& mf : map.voxel_points(k)) {
      const Vec3d m(mf.x, mf.y, mf.z);
      const double d = (m - p).squaredNorm();
      if (d < d2) {
        d2 = d;
        q = m;
        found = true;
      }
    }
  }
  return found;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Scans of a ground plane, a wall and scattered clutter around the sensor, some exact
// duplicates (ties), moved along x frame by frame; queries near and off the map.
TEST(OdometryVoxelMap, PrunedNearestMatchesPlainScanBitForBit) {
  static OdometryVoxelMap map;
  const double voxel = 1.0;
  map.configure(voxel, 20);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-12.0f, 12.0f), small(-0.05f, 0.05f);
  std::uint32_t dropped = 0, evicted = 0;
  std::size_t compared = 0, found = 0;
  // 3,000 points a frame, fewer where the map's capacity is small (EMBEDDED): the drive must fit.
  const int per_frame = static_cast<int>(3000 * std::min<std::size_t>(config::kOdometryMapPoints, 32768) / 32768);
  for (int frame = 0; frame < 12; ++frame) {
    std::vector<Vec3f> scan;
    for (int i = 0; i < per_frame; ++i) {
      const float x = u(rng), y = u(rng);
      switch (i % 4) {
        case 0: scan.emplace_back(x, y, -1.7f + small(rng)); break;            // ground
        case 1: scan.emplace_back(x, 6.0f + small(rng), 0.3f * y); break;     // wall
        case 2: scan.emplace_back(x, y, 0.2f * u(rng)); break;                // clutter
        default: scan.push_back(scan[scan.size() - 1 - (i % 3)]); break;      // duplicate
      }
    }
    Mat4d pose = Mat4d::Identity();
    pose(0, 3) = 1.3 * frame;
    pose.topLeftCorner<3, 3>() = so3_exp(Vec3d(0.0, 0.0, 0.05 * frame));
    map.update(scan, pose, 15.0, dropped, evicted);
    for (int i = 0; i < 2000; ++i) {
      const Vec3d p(pose(0, 3) + u(rng), u(rng), -1.7 + 0.1 * u(rng));
      const double max_d2 = (i % 3 == 0) ? 4.0 : 0.04 * (1 + i % 7);
      Vec3d q_new(0, 0, 0), q_ref(0, 0, 0);
      double d_new = 0.0, d_ref = 0.0;
      const bool f_new = map.nearest(p, max_d2, q_new, d_new);
      const bool f_ref = reference_nearest(map, voxel, p, max_d2, q_ref, d_ref);
      ASSERT_EQ(f_new, f_ref) << "frame " << frame << " query " << i;
      ++compared;
      if (!f_ref) continue;
      ++found;
      ASSERT_TRUE(same_bits(d_new, d_ref)) << d_new << " vs " << d_ref;
      for (int a = 0; a < 3; ++a) ASSERT_TRUE(same_bits(q_new(a), q_ref(a)));
    }
  }
  EXPECT_GT(evicted, 0u);  // the index was rebuilt at least once
  EXPECT_GT(found, compared / 4);
  EXPECT_EQ(dropped, 0u);
}

// A query through a remembered block (one per source point, kept across ICP-like iterations
// whose steps keep, shift or flip the block) returns bit for bit what a fresh query returns.
TEST(OdometryVoxelMap, RememberedBlockMatchesFreshQuery) {
  static OdometryVoxelMap map;
  map.configure(1.0, 20);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f), small(-0.05f, 0.05f);
  std::vector<Vec3f> scan;
  for (int i = 0; i < 2400; ++i) {
    const float x = u(rng), y = u(rng);
    if (i % 3 == 0) scan.emplace_back(x, y, -1.7f + small(rng));
    if (i % 3 == 1) scan.emplace_back(x, 5.0f + small(rng), 0.3f * y);
    if (i % 3 == 2) scan.emplace_back(x, y, 0.2f * u(rng));
  }
  std::uint32_t dropped = 0, evicted = 0;
  map.update(scan, Mat4d::Identity(), 30.0, dropped, evicted);
  constexpr int kPoints = 4000;
  std::vector<Vec3d> points;
  std::vector<OdometryVoxelMap::NeighborBlock> blocks(kPoints);
  for (int i = 0; i < kPoints; ++i) {
    points.emplace_back(u(rng), u(rng), i % 2 == 0 ? -1.7 + 0.05 * u(rng) : 0.1 * u(rng));
    blocks[i].lo[0] = OdometryVoxelMap::kNoBlock;
  }
  std::uniform_real_distribution<double> step(-0.6, 0.6);
  std::size_t found = 0, compared = 0;
  for (int it = 0; it < 8; ++it) {
    const double scale = it < 4 ? 1.0 : 0.01;  // large steps first, then converging ones
    for (int i = 0; i < kPoints; ++i) {
      if (it > 0) points[i] += scale * Vec3d(step(rng), step(rng), step(rng));
      const double max_d2 = (i % 2 == 0) ? 0.25 : 0.04;
      Vec3d q_block(0, 0, 0), q_fresh(0, 0, 0);
      double d_block = 0.0, d_fresh = 0.0;
      const bool f_block = map.nearest(points[i], max_d2, q_block, d_block, blocks[i]);
      const bool f_fresh = map.nearest(points[i], max_d2, q_fresh, d_fresh);
      ASSERT_EQ(f_block, f_fresh) << "iteration " << it << " point " << i;
      ++compared;
      if (!f_fresh) continue;
      ++found;
      ASSERT_TRUE(same_bits(d_block, d_fresh));
      for (int a = 0; a < 3; ++a) ASSERT_TRUE(same_bits(q_block(a), q_fresh(a)));
    }
  }
  EXPECT_GT(found, compared / 4);
  EXPECT_LT(found, compared);
}

// Every stored point is found in the voxel of its key, and nearest() finds a point itself.
TEST(OdometryVoxelMap, EveryPointReachableAfterIncrementalUpdates) {
  static OdometryVoxelMap map;
  map.configure(0.5, 5);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-8.0f, 8.0f);
  std::uint32_t dropped = 0, evicted = 0;
  for (int frame = 0; frame < 6; ++frame) {
    std::vector<Vec3f> scan;
    for (int i = 0; i < 1500; ++i) scan.emplace_back(u(rng), u(rng), 0.5f * u(rng));
    Mat4d pose = Mat4d::Identity();
    pose(1, 3) = 2.0 * frame;
    map.update(scan, pose, 9.0, dropped, evicted);
    std::size_t total = 0;
    for (const MapPoint& m : map.points()) {
      Vec3d q;
      double d2 = 1.0;
      ASSERT_TRUE(map.nearest(Vec3d(m.x, m.y, m.z), 1e-6, q, d2));
      EXPECT_EQ(d2, 0.0);
      ++total;
    }
    EXPECT_EQ(total, map.points().size());
  }
  EXPECT_GT(evicted, 0u);
}

}  // namespace
}  // namespace v2xloc
