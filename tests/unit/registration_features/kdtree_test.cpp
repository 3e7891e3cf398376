// k-d tree against brute force (3-D and 33-D): kNN, radius, hybrid, nearest; counters.
#include "v2xloc/algo/search/kdtree.hpp"

#include <gtest/gtest.h>

#include "random_points.hpp"

#include <algorithm>
#include <random>
#include <vector>

namespace v2xloc {
namespace {

using test::random_points;

template <class P>
float sq(const P& a, const P& b) {
  float s = 0.0f;
  for (int d = 0; d < P::RowsAtCompileTime; ++d) {
    const float t = a[d] - b[d];
    s += t * t;
  }
  return s;
}

// Brute force: all neighbours ascending (distance, index).
template <class P>
std::vector<Neighbor> brute(const std::vector<P>& pts, const P& q) {
  std::vector<Neighbor> all;
  for (std::size_t i = 0; i < pts.size(); ++i) all.push_back({std::uint32_t(i), sq(pts[i], q)});
  std::sort(all.begin(), all.end(), [](const Neighbor& a, const Neighbor& b) {
    return a.squared_distance < b.squared_distance ||
           (a.squared_distance == b.squared_distance && a.index < b.index);
  });
  return all;
}

template <class P>
void expect_same(const std::vector<Neighbor>& want, const Neighbor* got, std::size_t n) {
  ASSERT_EQ(want.size(), n);
  for (std::size_t k = 0; k < n; ++k) {
    EXPECT_EQ(want[k].index, got[k].index) << "rank " << k;
    // 33-D distances are summed in 8 lanes: equal up to float rounding of the order.
    EXPECT_NEAR(want[k].squared_distance, got[k].squared_distance,
                1e-5f * want[k].squared_distance);
  }
}

template <class P>
void check_against_brute_force(std::size_t n, float scale, float radius, std::uint32_t seed) {
  const auto pts = random_points<P>(n, seed, scale);
  const auto queries = random_points<P>(50, seed + 1, scale);
  std::vector<std::uint32_t> idx(n);
  std::vector<KdNode> nodes(kd_max_nodes(n));
  KdTree<P> tree;
  KdBuildParams bp;
  bp.max_node_visits = 1u << 30;  // exactness check: no cap
  const KdBuildResult b = tree.build(pts, idx, nodes, bp);
  ASSERT_EQ(b.status, KdBuildStatus::kOk);
  ASSERT_EQ(b.points_indexed, n);
  Neighbor buf[config::kMaxNeighbors];
  for (const P& q : queries) {
    const auto all = brute(pts, q);
    // kNN
    for (std::size_t k : {std::size_t{1}, std::size_t{7}, std::size_t{64}}) {
      const KdQueryResult r = tree.knn(q, k, std::span<Neighbor>(buf, config::kMaxNeighbors));
      expect_same<P>(std::vector<Neighbor>(all.begin(), all.begin() + k), buf, r.count);
      EXPECT_EQ(r.truncated, 0u);
      EXPECT_FALSE(r.visit_cap_hit);
    }
    // radius (strict <) and hybrid
    std::vector<Neighbor> in;
    for (const auto& a : all) {
      if (a.squared_distance < radius * radius) in.push_back(a);
    }
    if (in.size() <= config::kMaxNeighbors) {
      const KdQueryResult r = tree.radius(q, radius, std::span<Neighbor>(buf, config::kMaxNeighbors));
      expect_same<P>(in, buf, r.count);
      EXPECT_EQ(r.truncated, 0u);
    }
    const std::size_t max_nn = 30;
    const KdQueryResult h = tree.hybrid(q, radius, max_nn, std::span<Neighbor>(buf, max_nn));
    std::vector<Neighbor> want(in.begin(), in.begin() + std::min(in.size(), max_nn));
    expect_same<P>(want, buf, h.count);
    // nearest
    Neighbor nn{};
    const KdQueryResult r1 = tree.nearest(q, nn);
    ASSERT_EQ(r1.count, 1u);
    EXPECT_EQ(nn.index, all[0].index);
    EXPECT_NEAR(nn.squared_distance, all[0].squared_distance, 1e-5f * all[0].squared_distance);
  }
}

TEST(KdTree, MatchesBruteForce3D) { check_against_brute_force<Vec3f>(5000, 10.0f, 1.5f, 1); }
TEST(KdTree, MatchesBruteForce33D) { check_against_brute_force<Feature33>(2000, 1.0f, 2.2f, 2); }

TEST(KdTree, DuplicatePointsTieBreakByIndex) {
  std::vector<Vec3f> pts(100, Vec3f(1.0f, 2.0f, 3.0f));
  std::vector<std::uint32_t> idx(pts.size());
  std::vector<KdNode> nodes(kd_max_nodes(pts.size()));
  KdTree<Vec3f> tree;
  ASSERT_EQ(tree.build(pts, idx, nodes).status, KdBuildStatus::kOk);
  Neighbor buf[10];
  const KdQueryResult r = tree.knn(Vec3f(1.0f, 2.0f, 3.0f), 10, buf);
  ASSERT_EQ(r.count, 10u);
  for (std::uint32_t k = 0; k < 10; ++k) EXPECT_EQ(buf[k].index, k);
}

TEST(KdTree, NonFinitePointsAreNotIndexed) {
  auto pts = random_points<Vec3f>(200, 3, 1.0f);
  pts[5].x() = NAN;
  pts[17].z() = INFINITY;
  std::vector<std::uint32_t> idx(pts.size());
  std::vector<KdNode> nodes(kd_max_nodes(pts.size()));
  KdTree<Vec3f> tree;
  const KdBuildResult b = tree.build(pts, idx, nodes);
  EXPECT_EQ(b.non_finite_dropped, 2u);
  EXPECT_EQ(b.points_indexed, 198u);
  Neighbor nn{};
  EXPECT_EQ(tree.nearest(Vec3f(NAN, 0.0f, 0.0f), nn).count, 0u);  // non-finite query
  Neighbor buf[200];
  const KdQueryResult r = tree.radius(Vec3f::Zero(), 100.0f, buf);
  EXPECT_EQ(r.count, 198u);
  for (std::uint32_t k = 0; k < r.count; ++k) EXPECT_TRUE(buf[k].index != 5 && buf[k].index != 17);
}

TEST(KdTree, TruncationIsCounted) {
  const auto pts = random_points<Vec3f>(1000, 4, 1.0f);
  std::vector<std::uint32_t> idx(pts.size());
  std::vector<KdNode> nodes(kd_max_nodes(pts.size()));
  KdTree<Vec3f> tree;
  tree.build(pts, idx, nodes);
  Neighbor buf[16];
  // Radius covering everything: 16 kept (the nearest), 984 counted.
  const KdQueryResult r = tree.radius(Vec3f::Zero(), 10.0f, buf);
  EXPECT_EQ(r.count, 16u);
  EXPECT_EQ(r.truncated, 984u);
  const auto all = brute(pts, Vec3f(Vec3f::Zero()));
  for (int k = 0; k < 16; ++k) EXPECT_EQ(buf[k].index, all[k].index);
  // kNN asking more than fits.
  const KdQueryResult k = tree.knn(Vec3f::Zero(), 40, buf);
  EXPECT_EQ(k.count, 16u);
  EXPECT_EQ(k.truncated, 24u);
  // Hybrid with max_nn beyond the buffer: min(max_nn, in radius) - 16.
  const KdQueryResult h = tree.hybrid(Vec3f::Zero(), 10.0f, 30, buf);
  EXPECT_EQ(h.count, 16u);
  EXPECT_EQ(h.truncated, 14u);
  KdQueryCounters c;
  c.add(r);
  c.add(k);
  EXPECT_EQ(c.truncated, 984u + 24u);
  EXPECT_EQ(c.queries, 2u);
}

TEST(KdTree, VisitCapStopsTraversalAndIsReported) {
  const auto pts = random_points<Feature33>(3000, 5, 1.0f);
  std::vector<std::uint32_t> idx(pts.size());
  std::vector<KdNode> nodes(kd_max_nodes(pts.size()));
  KdTree<Feature33> tree;
  KdBuildParams bp;
  bp.max_node_visits = 20;  // > depth (~10): one leaf is reached, the search is far from done
  tree.build(pts, idx, nodes, bp);
  Neighbor nn{};
  const KdQueryResult r = tree.nearest(Feature33::Constant(0.01f), nn);
  EXPECT_TRUE(r.visit_cap_hit);
  EXPECT_EQ(r.node_visits, 20u);
  EXPECT_EQ(r.count, 1u);  // best so far is still returned
  Neighbor buf[8];
  const KdQueryResult k = tree.knn(Feature33::Constant(0.01f), 8, buf);
  EXPECT_TRUE(k.visit_cap_hit);
  EXPECT_LE(k.node_visits, 20u);
  EXPECT_EQ(k.count, 8u);
}

TEST(KdTree, BuildIsDeterministicAndEmptyIsHandled) {
  const auto pts = random_points<Vec3f>(4000, 6, 5.0f);
  static KdTreeStorage<Vec3f, 4000> a;
  static KdTreeStorage<Vec3f, 4000> b;
  ASSERT_EQ(a.build(pts).status, KdBuildStatus::kOk);
  ASSERT_EQ(b.build(pts).status, KdBuildStatus::kOk);
  EXPECT_TRUE(std::equal(std::begin(a.indices), std::end(a.indices), std::begin(b.indices)));
  KdTree<Vec3f> empty;
  Neighbor buf[4];
  EXPECT_EQ(empty.knn(Vec3f::Zero(), 4, buf).count, 0u);
  std::vector<Vec3f> none;
  EXPECT_EQ(a.build(none).status, KdBuildStatus::kEmpty);
  EXPECT_EQ(a.tree.knn(Vec3f::Zero(), 4, buf).count, 0u);
  // More points than the storage holds: the excess is counted.
  const auto many = random_points<Vec3f>(4100, 7, 1.0f);
  const KdBuildResult r = a.build(many);
  EXPECT_EQ(r.status, KdBuildStatus::kIndexStorageTooSmall);
  EXPECT_EQ(r.capacity_dropped, 100u);
}

}  // namespace
}  // namespace v2xloc
