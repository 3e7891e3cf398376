// Scan ingest: one pass over the raw sweep into voxel centroids (LiDAR frame), deskewed at each
// voxel's mean firing time; every dropped return is counted by its reason.
#include "v2xloc/algo/localization/scan_ingest.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {
namespace {

ScanIngest g_ingest;  // voxel tables: static

TEST(ScanIngest, MergesReturnsPerVoxelAndCountsEveryDrop) {
  std::vector<Vec3f> pts;
  // Two returns in the voxel [10, 10.5) x [0, 0.5) x [0, 0.5) and one in the next voxel.
  pts.emplace_back(10.1f, 0.1f, 0.1f);
  pts.emplace_back(10.3f, 0.3f, 0.3f);
  pts.emplace_back(10.6f, 0.1f, 0.1f);
  pts.emplace_back(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f);
  pts.emplace_back(std::numeric_limits<float>::infinity(), 0.0f, 0.0f);
  pts.emplace_back(1.0f, 0.0f, 0.0f);    // inside min_range: the ego body
  pts.emplace_back(200.0f, 0.0f, 0.0f);  // beyond max_range
  ScanIngestParams p;
  const ScanIngestResult r = g_ingest.run(pts, {}, nullptr, p);
  EXPECT_EQ(r.input_points, 7u);
  EXPECT_EQ(r.non_finite_dropped, 2u);
  EXPECT_EQ(r.range_dropped, 2u);
  EXPECT_EQ(r.capacity_dropped, 0u);
  ASSERT_EQ(r.voxels, 2u);
  EXPECT_FALSE(r.deskewed);
  const auto out = g_ingest.points();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_NEAR(out[0].x(), 10.2f, 1e-5f);  // centroid, first-occurrence order
  EXPECT_NEAR(out[0].y(), 0.2f, 1e-5f);
  EXPECT_NEAR(out[1].x(), 10.6f, 1e-5f);
}

TEST(ScanIngest, DeskewsEachVoxelAtItsMeanFiringTime) {
  // The sensor drives +x at 10 m/s: a return fired at t seconds is moved by the motion since 0.
  const std::vector<Vec3f> pts = {Vec3f(20.1f, 5.1f, 0.1f), Vec3f(20.1f, 5.1f, 0.1f), Vec3f(-20.1f, 5.1f, 0.1f)};
  const std::vector<float> times = {0.02f, 0.04f, 0.08f};
  Vec6d xi = Vec6d::Zero();
  xi(0) = 1.0;  // 1 m over the 0.1 s frame
  const Mat4d delta = se3_exp(xi);
  ScanIngestParams p;
  const ScanIngestResult r = g_ingest.run(pts, times, &delta, p);
  ASSERT_TRUE(r.deskewed);
  const auto out = g_ingest.points();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_NEAR(out[0].x(), 20.1f + 0.3f, 1e-4f);  // mean time 0.03 s -> 0.3 m
  EXPECT_NEAR(out[1].x(), -20.1f + 0.8f, 1e-4f);
  // A NaN firing time drops its return (counted) instead of poisoning the voxel's time.
  const std::vector<float> bad_times = {0.02f, std::numeric_limits<float>::quiet_NaN(), 0.08f};
  EXPECT_EQ(g_ingest.run(pts, bad_times, &delta, p).non_finite_dropped, 1u);
}

TEST(ScanIngest, OverflowingTheVoxelTableIsCountedNotSilent) {
  // More occupied voxels than the table holds: one return per 0.5 m voxel on a 3-D lattice.
  std::vector<Vec3f> pts;
  const int side = 40;  // 64000 voxels > kMaxDownsampledPoints on every profile
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j)
      for (int k = 0; k < side; ++k) pts.emplace_back(4.25f + 0.5f * i, 0.25f + 0.5f * j, 0.25f + 0.5f * k);
  ScanIngestParams p;
  p.max_range = 100.0f;
  p.max_coarsen_steps = 0;  // no coarser re-run: the overflow is dropped
  const ScanIngestResult r = g_ingest.run(pts, {}, nullptr, p);
  EXPECT_EQ(r.voxels, config::kMaxDownsampledPoints);
  EXPECT_EQ(r.coarsened, 0u);
  EXPECT_EQ(r.voxels + r.capacity_dropped + r.range_dropped, pts.size());
  EXPECT_GT(r.capacity_dropped, 0u);
  // The table is empty again: the next small scan is exact.
  const std::vector<Vec3f> one = {Vec3f(10.1f, 0.1f, 0.1f)};
  EXPECT_EQ(g_ingest.run(one, {}, nullptr, p).voxels, 1u);
  EXPECT_EQ(g_ingest.points()[0], one[0]);
}

// A flat square of one return per 0.5 m voxel, `times` as many voxels as the table holds (side x
// side of them).
std::vector<Vec3f> plane_of_voxels(double times, int& side) {
  side = static_cast<int>(std::ceil(std::sqrt(times * static_cast<double>(config::kMaxDownsampledPoints))));
  std::vector<Vec3f> pts;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j) pts.emplace_back(4.25f + 0.5f * i, 0.25f + 0.5f * j, 0.25f);
  return pts;
}

// A surface with more 0.5 m voxels than the table holds (1.5x) is read again with the voxel grown
// by 9/8 until it fits: nothing dropped, and the centroids still span the whole surface (cutting
// the overflow would drop the returns read last, i.e. whole sectors of a sweep).
TEST(ScanIngest, OverflowIsReadAgainWithACoarserVoxel) {
  int side = 0;
  const std::vector<Vec3f> pts = plane_of_voxels(1.5, side);
  ScanIngestParams p;
  p.max_range = 300.0f;
  const ScanIngestResult r = g_ingest.run(pts, {}, nullptr, p);
  EXPECT_EQ(r.capacity_dropped, 0u);
  EXPECT_GE(r.coarsened, 1u);
  EXPECT_LE(r.coarsened, p.max_coarsen_steps);
  EXPECT_FLOAT_EQ(r.voxel, p.voxel * std::pow(1.125f, static_cast<float>(r.coarsened)));
  EXPECT_LE(r.voxels, config::kMaxDownsampledPoints);
  EXPECT_EQ(r.voxels, g_ingest.points().size());
  float lo = 1e9f, hi = -1e9f;
  for (const Vec3f& q : g_ingest.points()) {
    lo = std::min(lo, q.x());
    hi = std::max(hi, q.x());
  }
  EXPECT_LT(lo, 4.25f + 2.0f * r.voxel);
  EXPECT_GT(hi, 4.25f + 0.5f * static_cast<float>(side - 1) - 2.0f * r.voxel);
  // The same surface again starts where it fit (the finer reads are not repeated): same output.
  const std::vector<Vec3f> first(g_ingest.points().begin(), g_ingest.points().end());
  const ScanIngestResult again = g_ingest.run(pts, {}, nullptr, p);
  EXPECT_EQ(again.coarsened, r.coarsened);
  EXPECT_EQ(again.voxel, r.voxel);
  // The period's work is priced by the reads: the first sweep read the surface more than once
  // (the table filled), this one once, though both are `coarsened` steps from the base voxel.
  EXPECT_GE(r.passes, 2u);
  EXPECT_LE(r.passes, r.coarsened + 1u);
  EXPECT_EQ(again.passes, 1u);
  EXPECT_TRUE(std::equal(first.begin(), first.end(), g_ingest.points().begin(), g_ingest.points().end()));
  // A scene that fits is read at the requested voxel once the previous sweep's voxels say it
  // may fit: the first sweep after the big one starts at the step the surface law allows.
  const std::vector<Vec3f> one = {Vec3f(10.1f, 0.1f, 0.1f)};
  g_ingest.run(one, {}, nullptr, p);
  const ScanIngestResult small = g_ingest.run(one, {}, nullptr, p);
  EXPECT_EQ(small.coarsened, 0u);
  EXPECT_EQ(small.voxel, p.voxel);
  EXPECT_EQ(g_ingest.points()[0], one[0]);
  // After forget_steps() the base voxel is read first.
  g_ingest.run(pts, {}, nullptr, p);
  g_ingest.forget_steps();
  EXPECT_EQ(g_ingest.run(one, {}, nullptr, p).coarsened, 0u);
}

// A first sweep far over the capacity (4x the table's 0.5 m voxels, no history) is coarsened in
// one jump from the share of the sweep that filled the table: it lands on the finest step at which
// the surface fits, or the next (the surface law's estimate), never drops a return, and a finer
// step would have overflowed.
TEST(ScanIngest, FarOverflowJumpsToTheStepThatFits) {
  int side = 0;
  const std::vector<Vec3f> pts = plane_of_voxels(4.0, side);
  ScanIngestParams p;
  p.max_range = 300.0f;
  // The finest fitting step, by reading the surface at each step with no coarsening.
  std::uint32_t finest = 0;
  for (;; ++finest) {
    ScanIngestParams fixed = p;
    fixed.max_coarsen_steps = 0;
    for (std::uint32_t k = 0; k < finest; ++k) fixed.voxel *= 1.125f;
    g_ingest.forget_steps();
    if (g_ingest.run(pts, {}, nullptr, fixed).capacity_dropped == 0) break;
    ASSERT_LT(finest, p.max_coarsen_steps);
  }
  ASSERT_GE(finest, 3u);  // far over: a step-by-step reading would read the sweep >= 4 times
  g_ingest.forget_steps();
  const ScanIngestResult r = g_ingest.run(pts, {}, nullptr, p);
  EXPECT_EQ(r.capacity_dropped, 0u);
  EXPECT_GE(r.coarsened, finest);
  EXPECT_LE(r.coarsened, finest + 1);
  EXPECT_LE(r.voxels, config::kMaxDownsampledPoints);
  EXPECT_EQ(r.range_dropped + r.non_finite_dropped, 0u);
}

}  // namespace
}  // namespace v2xloc
