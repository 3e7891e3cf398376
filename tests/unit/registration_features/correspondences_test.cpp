// Feature matching: one-way nearest neighbour vs brute force, mutual filter, fallback, capacity.
#include "v2xloc/algo/registration/correspondences.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace v2xloc {
namespace {

std::vector<Feature33> random_features(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 100.0f);
  std::vector<Feature33> f(n);
  for (auto& x : f)
    for (int b = 0; b < kFpfhBins; ++b) x[b] = u(rng);
  return f;
}

std::uint32_t brute_nn(const std::vector<Feature33>& set, const Feature33& q) {
  std::uint32_t best = 0;
  float best_d = INFINITY;
  for (std::size_t i = 0; i < set.size(); ++i) {
    float d = 0.0f;
    for (int b = 0; b < kFpfhBins; ++b) d += (set[i][b] - q[b]) * (set[i][b] - q[b]);
    if (d < best_d) {
      best_d = d;
      best = std::uint32_t(i);
    }
  }
  return best;
}

static KdTreeStorage<Feature33, 4000> src_tree;
static KdTreeStorage<Feature33, 4000> tgt_tree;
static FixedVector<Correspondence, 4000> out;
static std::uint32_t scratch[4000];

TEST(Correspondences, OneWayAndMutualMatchBruteForce) {
  const auto src = random_features(1500, 1);
  auto tgt = random_features(1200, 2);
  // Plant 300 near-copies so there are real mutual matches.
  for (int k = 0; k < 300; ++k) tgt[4 * k] = src[5 * k] + Feature33::Constant(0.01f);
  ASSERT_EQ(src_tree.build(src, 1u << 30).status, KdBuildStatus::kOk);
  ASSERT_EQ(tgt_tree.build(tgt, 1u << 30).status, KdBuildStatus::kOk);

  CorrespondenceParams p;
  CorrespondenceResult r = match_features(src, tgt_tree.tree, p, out);
  ASSERT_EQ(r.status, CorrespondenceStatus::kOk);
  ASSERT_EQ(r.count, src.size());
  for (std::size_t i = 0; i < src.size(); ++i) {
    EXPECT_EQ(out[i].source, i);
    EXPECT_EQ(out[i].target, brute_nn(tgt, src[i]));
  }

  p.mutual_filter = true;
  r = match_features(src, tgt_tree.tree, p, out, &src_tree.tree, scratch);
  ASSERT_EQ(r.status, CorrespondenceStatus::kOk);
  EXPECT_FALSE(r.fell_back);
  std::size_t want = 0;
  for (std::size_t i = 0; i < src.size(); ++i) {
    const std::uint32_t j = brute_nn(tgt, src[i]);
    if (brute_nn(src, tgt[j]) == i) ++want;
  }
  EXPECT_EQ(r.count, want);
  EXPECT_GE(r.count, 300u);
  EXPECT_EQ(r.count + r.mutual_rejected, src.size());
  for (const auto& c : out) {
    EXPECT_EQ(brute_nn(tgt, src[c.source]), c.target);
    EXPECT_EQ(brute_nn(src, tgt[c.target]), c.source);
  }
}

TEST(Correspondences, MutualFallbackAndCapacity) {
  const auto src = random_features(500, 3);
  const auto tgt = random_features(500, 4);
  src_tree.build(src);
  tgt_tree.build(tgt);
  CorrespondenceParams p;
  p.mutual_filter = true;
  p.min_mutual = 100000;  // unreachable: falls back to the one-way set
  CorrespondenceResult r = match_features(src, tgt_tree.tree, p, out, &src_tree.tree, scratch);
  EXPECT_TRUE(r.fell_back);
  EXPECT_EQ(r.count, 500u);
  EXPECT_EQ(match_features(src, tgt_tree.tree, p, out).status,
            CorrespondenceStatus::kInvalidStorage);
  static FixedVector<Correspondence, 100> small;
  p.mutual_filter = false;
  r = match_features(src, tgt_tree.tree, p, small);
  EXPECT_EQ(r.count, 100u);
  EXPECT_EQ(r.truncated, 400u);
  auto bad = src;
  bad[7][3] = NAN;
  r = match_features(bad, tgt_tree.tree, p, out);
  EXPECT_EQ(r.no_match, 1u);
  EXPECT_EQ(r.count, 499u);
  EXPECT_EQ(match_features({}, tgt_tree.tree, p, out).status, CorrespondenceStatus::kEmptyInput);
}

// FPFH-like features: three 11-bin blocks summing to 100 each, with planted near-copies and
// exact duplicates (ties) so both the filter's margin and the index tie-break are exercised.
std::vector<Feature33> histogram_features(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::gamma_distribution<float> g(0.5f, 1.0f);
  std::vector<Feature33> f(n);
  for (auto& x : f) {
    for (int block = 0; block < 3; ++block) {
      float sum = 0.0f;
      for (int b = 0; b < 11; ++b) sum += x[block * 11 + b] = g(rng) + (b == 5 ? 4.0f : 0.0f);
      for (int b = 0; b < 11; ++b) x[block * 11 + b] *= 100.0f / sum;
    }
  }
  return f;
}

static FeatureBasis basis;
static float src_proj[4000 * 8];
static float tgt_proj[4000 * 8];

// The principal-axis projection pre-filter changes the work, never the matches.
TEST(Correspondences, ProjectionFilterGivesIdenticalMatches) {
  const auto src = histogram_features(1500, 5);
  auto tgt = histogram_features(1400, 6);
  for (int k = 0; k < 200; ++k) tgt[7 * k] = src[3 * k] + Feature33::Constant(0.001f * float(k % 3));
  tgt[1] = tgt[2];  // duplicate target: ties
  ASSERT_EQ(src_tree.build(src).status, KdBuildStatus::kOk);
  ASSERT_EQ(tgt_tree.build(tgt).status, KdBuildStatus::kOk);
  CorrespondenceParams p;
  p.mutual_filter = true;
  static FixedVector<Correspondence, 4000> plain;
  const CorrespondenceResult a = match_features(src, tgt_tree.tree, p, plain, &src_tree.tree, scratch);

  static Feature33 jacobi[2 * kFpfhBins];
  EXPECT_FALSE(compute_feature_basis(src, tgt, 3, std::span<Feature33>(jacobi, 10), basis));
  ASSERT_TRUE(compute_feature_basis(src, tgt, 3, jacobi, basis));
  // The axes are orthonormal.
  for (int i = 0; i < FeatureBasis::kAxes; ++i) {
    for (int j = 0; j < FeatureBasis::kAxes; ++j) {
      double dot = 0.0;
      for (int d = 0; d < kFpfhBins; ++d) dot += basis.axes[i][d] * basis.axes[j][d];
      EXPECT_NEAR(dot, i == j ? 1.0 : 0.0, 1e-12);
    }
  }
  const float max_abs = std::max(project_features(src, basis, src_proj, 8),
                                 project_features(tgt, basis, tgt_proj, 8));
  src_tree.tree.set_projections(src_proj, 8, max_abs);
  tgt_tree.tree.set_projections(tgt_proj, 8, max_abs);
  p.projections = {src_proj, tgt_proj, 8};
  const CorrespondenceResult b = match_features(src, tgt_tree.tree, p, out, &src_tree.tree, scratch);
  ASSERT_EQ(b.count, a.count);
  EXPECT_GT(b.count, 150u);
  EXPECT_EQ(b.mutual_rejected, a.mutual_rejected);
  for (std::size_t k = 0; k < a.count; ++k) {
    EXPECT_EQ(out[k].source, plain[k].source);
    EXPECT_EQ(out[k].target, plain[k].target);
  }
  EXPECT_LT(b.search.node_visits, a.search.node_visits + 1);  // same tree, same traversal
  // One-way too (every source's nearest target).
  p.mutual_filter = false;
  match_features(src, tgt_tree.tree, p, out);
  for (std::size_t i = 0; i < src.size(); ++i) {
    Neighbor nn{};
    tgt_tree.tree.nearest(src[i], nn);
    EXPECT_EQ(out[i].target, nn.index);
  }
  // A hint (any point, or none) with the projection filter seeds the bound, never the answer.
  for (std::size_t i = 0; i < src.size(); i += 7) {
    Neighbor plain_nn{}, hinted{}, unhinted{};
    tgt_tree.tree.nearest(src[i], plain_nn);
    const auto hint = static_cast<std::uint32_t>((i * 37) % tgt.size());
    ASSERT_EQ(tgt_tree.tree.nearest(src[i], src_proj + 8 * i, hint, hinted).count, 1u);
    tgt_tree.tree.nearest(src[i], src_proj + 8 * i, KdTree<Feature33>::kNoHint, unhinted);
    EXPECT_EQ(hinted.index, plain_nn.index);
    EXPECT_EQ(hinted.squared_distance, plain_nn.squared_distance);
    EXPECT_EQ(unhinted.index, plain_nn.index);
  }
}

}  // namespace
}  // namespace v2xloc
