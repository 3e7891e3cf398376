// PCA normals on analytic surfaces, orientation, degenerate neighbourhoods, eigen solver.
#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/registration/lazy_normals.hpp"
#include "v2xloc/algo/core/symmetric_eigen.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace v2xloc {
namespace {

static KdTreeStorage<Vec3f, 20000> tree_storage;
static Vec3f normals[20000];
static NormalQuality quality[20000];

TEST(SymmetricEigen3, DiagonalisesRandomMatrices) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int t = 0; t < 200; ++t) {
    Mat3d m;
    for (int i = 0; i < 3; ++i)
      for (int j = i; j < 3; ++j) m(i, j) = m(j, i) = u(rng);
    Vec3d lambda;
    Mat3d v;
    symmetric_eigen3(m, lambda, v);
    EXPECT_LE(lambda[0], lambda[1]);
    EXPECT_LE(lambda[1], lambda[2]);
    EXPECT_LT((m * v - v * lambda.asDiagonal()).norm(), 1e-12);
    EXPECT_LT((v.transpose() * v - Mat3d::Identity()).norm(), 1e-12);
  }
}

TEST(Normals, PlaneNormalsExactAndOrientedTowardViewpoint) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-5.0f, 5.0f);
  const Vec3d n_true = Vec3d(0.3, -0.2, 1.0).normalized();
  std::vector<Vec3f> pts(5000);
  for (auto& p : pts) {
    const double x = u(rng), y = u(rng);
    p = Vec3f(float(x), float(y), float((1.0 - 0.3 * x + 0.2 * y) / 1.0));  // n . p = const
  }
  ASSERT_EQ(tree_storage.build(pts).status, KdBuildStatus::kOk);
  NormalParams np;
  np.radius = 0.5f;
  np.viewpoint = Vec3f(0.0f, 0.0f, 100.0f);
  const NormalsResult r = estimate_normals(tree_storage.tree, np, normals, quality);
  ASSERT_EQ(r.status, NormalsStatus::kOk);
  EXPECT_EQ(r.points, 5000u);
  int good = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (quality[i] != NormalQuality::kOk) continue;
    EXPECT_GT(normals[i].cast<double>().dot(n_true), 0.9999) << i;  // and oriented (+)
    ++good;
  }
  EXPECT_GE(good, 4990);
  EXPECT_EQ(r.search.queries, 5000u);
}

TEST(Normals, SphereNormalsRadialAndOutward) {
  std::mt19937 rng(3);
  std::normal_distribution<float> g;
  std::vector<Vec3f> pts(8000);
  for (auto& p : pts) {
    Vec3f d(g(rng), g(rng), g(rng));
    p = 2.0f * d.normalized();
  }
  ASSERT_EQ(tree_storage.build(pts).status, KdBuildStatus::kOk);
  NormalParams np;
  np.radius = 0.3f;
  np.viewpoint = Vec3f(0.0f, 0.0f, 0.0f);  // centre: oriented inward
  estimate_normals(tree_storage.tree, np, normals, quality);
  double worst = 1.0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    worst = std::min(worst, -double(normals[i].dot(pts[i].normalized())));
  }
  EXPECT_GT(worst, 0.99);  // curvature bias over a 0.3 m patch of a 2 m sphere is small
}

TEST(Normals, DegenerateNeighbourhoodsFlagged) {
  std::vector<Vec3f> pts;
  for (int i = 0; i < 50; ++i) pts.push_back(Vec3f(0.1f * float(i), 0.0f, 0.0f));  // a line
  pts.push_back(Vec3f(100.0f, 100.0f, 100.0f));                                    // isolated
  pts.push_back(Vec3f(NAN, 0.0f, 0.0f));
  ASSERT_EQ(tree_storage.build(pts).status, KdBuildStatus::kOk);
  NormalParams np;
  np.radius = 0.35f;
  np.viewpoint = Vec3f(0.0f, 10.0f, 0.0f);
  const NormalsResult r = estimate_normals(tree_storage.tree, np, normals, quality);
  EXPECT_EQ(r.few_neighbors, 1u);
  EXPECT_EQ(r.non_finite, 1u);
  EXPECT_EQ(r.collinear, 50u);
  for (int i = 0; i < 50; ++i) {
    EXPECT_EQ(quality[i], NormalQuality::kCollinear);
    // Perpendicular to the line, toward the viewpoint (0,10,0): (0,1,0).
    EXPECT_NEAR(normals[i].y(), 1.0f, 1e-5f);
  }
  EXPECT_EQ(quality[50], NormalQuality::kFewNeighbors);
  EXPECT_EQ(normals[50], Vec3f(0.0f, 0.0f, -1.0f));  // (0,0,1) flipped toward the viewpoint
  EXPECT_EQ(quality[51], NormalQuality::kNonFinitePoint);
  np.radius = -1.0f;
  EXPECT_EQ(estimate_normals(tree_storage.tree, np, normals).status, NormalsStatus::kInvalidParams);
  KdTree<Vec3f> empty;
  EXPECT_EQ(estimate_normals(empty, NormalParams{}, normals).status, NormalsStatus::kEmptyTree);
}

// Normals on first use: each one the bits estimate_normals() gives, in any order of asking; the
// per-period quota answers NaN past it and counts; reset forgets; out-of-range indices are NaN.
TEST(LazyNormals, SameBitsAsTheWholeCloudAndQuotaCounted) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  std::vector<Vec3f> pts(3000);
  for (auto& p : pts) p = Vec3f(u(rng), u(rng), 0.1f * std::sin(u(rng)));
  pts[7] = Vec3f(NAN, 0.0f, 0.0f);
  ASSERT_EQ(tree_storage.build(pts).status, KdBuildStatus::kOk);
  NormalParams np;
  np.radius = 0.6f;
  np.orient_to_viewpoint = false;
  estimate_normals(tree_storage.tree, np, normals);
  static Vec3f lazy_storage[20000];
  static std::uint64_t done[(20000 + 63) / 64];
  LazyNormals lazy;
  lazy.reset(&tree_storage.tree, np, lazy_storage, done, 0);
  for (std::uint32_t k = 0; k < 6000; ++k) {  // every point, twice, in a scrambled order
    const std::uint32_t i = (k * 1237u) % 3000u;
    const Vec3f n = lazy.get(i);
    ASSERT_TRUE(n == normals[i]) << i;
  }
  EXPECT_EQ(lazy.new_period(100).computed, 3000u);
  lazy.reset(&tree_storage.tree, np, lazy_storage, done, 100);
  for (std::uint32_t i = 0; i < 150; ++i) {
    const Vec3f n = lazy.get(i);
    if (i < 100) {
      EXPECT_TRUE(n == normals[i]) << i;
    } else {
      EXPECT_FALSE(n.allFinite()) << i;
    }
  }
  EXPECT_TRUE(lazy.get(42) == normals[42]) << "a computed normal stays available past the quota";
  const LazyNormalCounters c = lazy.new_period(100);
  EXPECT_EQ(c.computed, 100u);
  EXPECT_EQ(c.refused, 50u);
  EXPECT_TRUE(lazy.get(120) == normals[120]) << "the next period computes it";
  EXPECT_FALSE(lazy.get(3000).allFinite());
  EXPECT_FALSE(lazy.get(0xFFFFFFFFu).allFinite());
}

}  // namespace
}  // namespace v2xloc
