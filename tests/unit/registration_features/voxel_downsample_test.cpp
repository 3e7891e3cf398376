// Voxel downsampling against a brute-force centroid computation; determinism; counters.
#include "v2xloc/algo/registration/voxel_downsample.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <tuple>
#include <vector>

namespace v2xloc {
namespace {

using Key = std::tuple<long, long, long>;

// Reference: Open3D's rule written the obvious way, centroids in first-occurrence order.
std::vector<Vec3f> brute_centroids(const std::vector<Vec3f>& pts, float voxel) {
  double lo[3] = {INFINITY, INFINITY, INFINITY};
  for (const auto& p : pts) {
    if (!p.allFinite()) continue;
    for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], double(p[d]));
  }
  std::map<Key, std::size_t> slot;
  std::vector<Vec3d> sum;
  std::vector<int> count;
  for (const auto& p : pts) {
    if (!p.allFinite()) continue;
    long i[3];
    for (int d = 0; d < 3; ++d) {
      i[d] = long(std::floor((double(p[d]) - (lo[d] - double(voxel) * 0.5)) / double(voxel)));
    }
    const Key k{i[0], i[1], i[2]};
    auto it = slot.find(k);
    if (it == slot.end()) {
      it = slot.emplace(k, sum.size()).first;
      sum.push_back(Vec3d::Zero());
      count.push_back(0);
    }
    sum[it->second] += p.cast<double>();
    ++count[it->second];
  }
  std::vector<Vec3f> out;
  for (std::size_t v = 0; v < sum.size(); ++v) out.push_back((sum[v] / count[v]).cast<float>());
  return out;
}

std::vector<Vec3f> random_cloud(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-20.0f, 20.0f);
  std::vector<Vec3f> pts(n);
  for (auto& p : pts) p = Vec3f(u(rng), u(rng), 0.1f * u(rng));
  return pts;
}

static VoxelDownsampleStorage<65536, 20000> storage;
static FixedVector<Vec3f, 20000> out;

TEST(VoxelDownsample, MatchesBruteForceCentroidsInFirstOccurrenceOrder) {
  const auto pts = random_cloud(30000, 1);
  const auto want = brute_centroids(pts, 0.7f);
  const VoxelDownsampleResult r = storage.run(pts, 0.7f, out);
  ASSERT_EQ(r.status, VoxelStatus::kOk);
  ASSERT_EQ(r.output_points, want.size());
  ASSERT_EQ(out.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(out[i], want[i]) << i;  // same double sums in the same order: same bits
  }
  EXPECT_GT(want.size(), 1000u);
}

TEST(VoxelDownsample, DeterministicAndTableLeftEmpty) {
  const auto pts = random_cloud(20000, 2);
  storage.run(pts, 0.5f, out);
  std::vector<Vec3f> first(out.begin(), out.end());
  storage.run(pts, 0.5f, out);
  ASSERT_EQ(first.size(), out.size());
  for (std::size_t i = 0; i < first.size(); ++i) EXPECT_EQ(first[i], out[i]);
  for (const auto& s : storage.slots) ASSERT_EQ(s.voxel_plus_one, 0u);
}

TEST(VoxelDownsample, NonFiniteDroppedAndCounted) {
  auto pts = random_cloud(1000, 3);
  pts[3].x() = NAN;
  pts[10].y() = INFINITY;
  pts[11].z() = -INFINITY;
  const VoxelDownsampleResult r = storage.run(pts, 1.0f, out);
  EXPECT_EQ(r.status, VoxelStatus::kOk);
  EXPECT_EQ(r.non_finite_dropped, 3u);
  EXPECT_EQ(out.size(), brute_centroids(pts, 1.0f).size());
  for (const auto& p : out) EXPECT_TRUE(p.allFinite());
  std::vector<Vec3f> all_nan(5, Vec3f(NAN, NAN, NAN));
  EXPECT_EQ(storage.run(all_nan, 1.0f, out).status, VoxelStatus::kEmptyInput);
  EXPECT_EQ(storage.run({}, 1.0f, out).status, VoxelStatus::kEmptyInput);
  EXPECT_EQ(storage.run(pts, 0.0f, out).status, VoxelStatus::kInvalidVoxelSize);
  EXPECT_EQ(storage.run(pts, NAN, out).status, VoxelStatus::kInvalidVoxelSize);
}

TEST(VoxelDownsample, OutputOverflowCounted) {
  const auto pts = random_cloud(20000, 4);
  static FixedVector<Vec3f, 100> small;
  const VoxelDownsampleResult r = storage.run(pts, 0.3f, small);
  EXPECT_EQ(r.status, VoxelStatus::kTruncated);
  EXPECT_EQ(small.size(), 100u);
  EXPECT_GT(r.output_overflow, 0u);
  // Every finite point is either in a kept voxel or counted.
  const auto want = brute_centroids(pts, 0.3f);
  for (std::size_t i = 0; i < 100; ++i) EXPECT_EQ(small[i], want[i]);  // first 100 voxels kept
  for (const auto& s : storage.slots) ASSERT_EQ(s.voxel_plus_one, 0u);
}

TEST(VoxelDownsample, StopWhenFullEndsAtTheOverflowAndLeavesTheTableEmpty) {
  const auto pts = random_cloud(20000, 4);
  static FixedVector<Vec3f, 100> small;
  const VoxelDownsampleResult r = storage.run(pts, 0.3f, small, SIZE_MAX, true);
  EXPECT_EQ(r.status, VoxelStatus::kStoppedFull);
  EXPECT_EQ(r.output_overflow, 1u);
  EXPECT_TRUE(small.empty());
  for (const auto& s : storage.slots) ASSERT_EQ(s.voxel_plus_one, 0u);
  // A cloud that fits is unaffected: the same centroids as without the flag.
  const VoxelDownsampleResult fits = storage.run(pts, 0.7f, out, SIZE_MAX, true);
  EXPECT_EQ(fits.status, VoxelStatus::kOk);
  const auto want = brute_centroids(pts, 0.7f);
  ASSERT_EQ(out.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) EXPECT_EQ(out[i], want[i]);
}

TEST(VoxelDownsample, HashOverflowCountedWithTinyTable) {
  const auto pts = random_cloud(5000, 5);
  static VoxelHashSlot slots[64];
  static VoxelAccumulator acc[20000];
  const VoxelDownsampleResult r = voxel_downsample(pts, 0.3f, slots, acc, out);
  EXPECT_EQ(r.status, VoxelStatus::kTruncated);
  EXPECT_EQ(r.output_points, 64u);  // every slot used once
  EXPECT_GT(r.hash_overflow, 0u);
  EXPECT_LE(r.max_probe, config::kVoxelMaxProbes);
  static VoxelHashSlot bad_slots[48];
  EXPECT_EQ(voxel_downsample(pts, 0.3f, bad_slots, acc, out).status, VoxelStatus::kInvalidStorage);
}

TEST(VoxelDownsample, HugeRangeCounted) {
  std::vector<Vec3f> pts = {Vec3f(0, 0, 0), Vec3f(1e9f, 0, 0), Vec3f(0.1f, 0, 0)};
  const VoxelDownsampleResult r = storage.run(pts, 0.01f, out);
  EXPECT_EQ(r.range_overflow, 1u);
  EXPECT_EQ(r.status, VoxelStatus::kTruncated);
  EXPECT_EQ(out.size(), 2u);
}

}  // namespace
}  // namespace v2xloc
