#include "v2xloc/algo/registration/correspondences.hpp"

#include <cmath>

#include "v2xloc/algo/core/finite.hpp"
#include "v2xloc/algo/core/symmetric_eigen.hpp"

namespace v2xloc {

namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;  // no candidate source for a target

// Source -> target, in source order. With the mutual filter, scratch[j] collects the closest
// source among those matched to target j ((distance, index) order, like the tree's ties):
// only that one can be j's nearest source.
void match_sources(std::span<const Feature33> source_features, const KdTree<Feature33>& target_tree,
                   const CorrespondenceParams& params, std::span<std::uint32_t> scratch,
                   BoundedVector<Correspondence>& out, CorrespondenceResult& r) {
  const std::span<const Feature33> targets = target_tree.points();
  // Consecutive sources are usually spatial neighbours (downsampled clouds come out in voxel
  // order) with similar features: the previous match seeds the bound. The exact result does
  // not depend on it; under a visit budget (approximate search) it improves the answer.
  std::uint32_t hint = KdTree<Feature33>::kNoHint;
  for (std::size_t i = 0; i < source_features.size(); ++i) {
    Neighbor nn{};
    const FeatureProjections& fp = params.projections;
    const float* qp = fp.source != nullptr ? fp.source + i * fp.stride : nullptr;
    const KdQueryResult kr = target_tree.nearest(source_features[i], qp, hint, nn);
    if (kr.count > 0) hint = nn.index;
    r.search.add(kr);
    if (kr.count == 0) {
      ++r.no_match;
      continue;
    }
    if (!out.push_back({static_cast<std::uint32_t>(i), nn.index})) ++r.truncated;
    if (params.mutual_filter) {
      std::uint32_t& best = scratch[nn.index];
      // Ascending i: an equal distance keeps the earlier (lower) index.
      if (best == kNone || nn.squared_distance < KdTree<Feature33>::squared_distance(
                                                     targets[nn.index], source_features[best])) {
        best = static_cast<std::uint32_t>(i);
      }
    }
  }
}

// (i, j) is mutual iff no source is closer to target j than i. Instead of a full nearest
// search per target (Open3D's second kNN pass) only the candidate targets are checked, each
// with the candidate's distance as the initial bound and an exit at the first closer source:
// the same set as comparing both nearest-neighbour maps, at a fraction of the cost.
// Candidates that are not mutual are cleared from scratch.
void drop_non_mutual_candidates(std::span<const Feature33> source_features,
                                std::span<const Feature33> targets,
                                const KdTree<Feature33>& source_tree, const FeatureProjections& fp,
                                std::span<std::uint32_t> scratch, CorrespondenceResult& r) {
  for (std::size_t j = 0; j < targets.size(); ++j) {
    const std::uint32_t i = scratch[j];
    if (i == kNone) continue;
    const Neighbor candidate{i, KdTree<Feature33>::squared_distance(targets[j], source_features[i])};
    bool closer_exists = false;
    const float* qp = fp.target != nullptr ? fp.target + j * fp.stride : nullptr;
    const KdQueryResult kr = source_tree.has_closer(targets[j], qp, candidate, closer_exists);
    r.search.add(kr);
    if (closer_exists) scratch[j] = kNone;
  }
}

// Keeps the mutual pairs (scratch[target] == source) when there are at least min_mutual of
// them, else the one-way set (fell_back).
void keep_mutual(std::span<const std::uint32_t> scratch, std::size_t min_mutual,
                 BoundedVector<Correspondence>& out, CorrespondenceResult& r) {
  std::size_t mutual = 0;
  for (const Correspondence& c : out) {
    if (scratch[c.target] == c.source) ++mutual;
  }
  if (mutual < min_mutual) {
    r.fell_back = true;
    return;
  }
  std::size_t w = 0;
  for (std::size_t k = 0; k < out.size(); ++k) {
    if (scratch[out[k].target] == out[k].source) out[w++] = out[k];
  }
  r.mutual_rejected = static_cast<std::uint32_t>(out.size() - w);
  out.resize(w);
}

}  // namespace

CorrespondenceResult match_features(std::span<const Feature33> source_features,
                                    const KdTree<Feature33>& target_tree,
                                    const CorrespondenceParams& params,
                                    BoundedVector<Correspondence>& out,
                                    const KdTree<Feature33>* source_tree,
                                    std::span<std::uint32_t> scratch) {
  CorrespondenceResult r;
  out.clear();
  if (source_features.empty() || target_tree.empty()) {
    r.status = CorrespondenceStatus::kEmptyInput;
    return r;
  }
  const std::size_t num_target = target_tree.points().size();
  if (params.mutual_filter &&
      (source_tree == nullptr || source_tree->empty() || scratch.size() < num_target)) {
    r.status = CorrespondenceStatus::kInvalidStorage;
    return r;
  }
  if (params.mutual_filter) {
    for (std::size_t j = 0; j < num_target; ++j) scratch[j] = kNone;
  }
  match_sources(source_features, target_tree, params, scratch, out, r);
  if (params.mutual_filter) {
    drop_non_mutual_candidates(source_features, target_tree.points(), *source_tree,
                               params.projections, scratch, r);
    keep_mutual(scratch, params.min_mutual, out, r);
  }
  r.count = static_cast<std::uint32_t>(out.size());
  r.status = r.count > 0 ? CorrespondenceStatus::kOk : CorrespondenceStatus::kNoMatches;
  return r;
}

namespace {

constexpr int kN = kFpfhBins;

// Rows of Feature33 seen as a matrix, for the core's Jacobi sweep.
struct FeatureRows {
  Feature33* rows;
  float& operator()(int i, int j) { return rows[i][j]; }
};

// Cyclic Jacobi on the symmetric a (core/symmetric_eigen.hpp; rows are Feature33), rotations
// accumulated in v: +,-,*,/,sqrt only in a fixed order, so the same bits on every ISA. Float is
// enough for a pruning basis: v stays orthonormal to ~1e-6 whatever the convergence, far inside
// the filter's 1e-4 margin.
void jacobi_eigen(Feature33* a, Feature33* v) {
  for (int i = 0; i < kN; ++i) {
    for (int j = 0; j < kN; ++j) v[i][j] = i == j ? 1.0f : 0.0f;
  }
  float total = 0.0f;
  for (int i = 0; i < kN; ++i) {
    for (int j = 0; j < kN; ++j) total += a[i][j] * a[i][j];
  }
  FeatureRows rows_a{a}, rows_v{v};
  for (int sweep = 0; sweep < 12; ++sweep) {
    float off = 0.0f;
    for (int i = 0; i < kN; ++i) {
      for (int j = i + 1; j < kN; ++j) off += a[i][j] * a[i][j];
    }
    if (!(off > 1e-12f * total)) break;
    jacobi_sweep<float, kN>(rows_a, &rows_v);
  }
}

}  // namespace

bool compute_feature_basis(std::span<const Feature33> a, std::span<const Feature33> b,
                           std::size_t sample_stride, std::span<Feature33> scratch,
                           FeatureBasis& basis) {
  if (scratch.size() < 2 * static_cast<std::size_t>(kN)) return false;
  const std::size_t stride = sample_stride > 0 ? sample_stride : 1;
  for (double& m : basis.mean) m = 0.0;
  std::size_t count = 0;
  for (const std::span<const Feature33> set : {a, b}) {
    for (std::size_t i = 0; i < set.size(); i += stride) {
      if (!is_finite_point(set[i])) continue;
      for (int d = 0; d < kN; ++d) basis.mean[d] += set[i][d];
      ++count;
    }
  }
  if (count > 0) {
    for (double& m : basis.mean) m /= static_cast<double>(count);
  }
  // Covariance row by row (double sums over the same samples in a fixed order), stored as float.
  Feature33* cov = scratch.data();
  for (int d = 0; d < kN; ++d) {
    double row[kN] = {};
    for (const std::span<const Feature33> set : {a, b}) {
      for (std::size_t i = 0; i < set.size(); i += stride) {
        if (!is_finite_point(set[i])) continue;
        const double cd = set[i][d] - basis.mean[d];
        for (int e = d; e < kN; ++e) row[e] += cd * (set[i][e] - basis.mean[e]);
      }
    }
    for (int e = d; e < kN; ++e) cov[d][e] = cov[e][d] = static_cast<float>(row[e]);
  }
  Feature33* vectors = scratch.data() + kN;
  jacobi_eigen(cov, vectors);
  // The kAxes largest eigenvalues (ties: lower index), eigenvectors = columns of vectors.
  bool used[kN] = {};
  for (int k = 0; k < FeatureBasis::kAxes; ++k) {
    int best = -1;
    for (int j = 0; j < kN; ++j) {
      if (!used[j] && (best < 0 || cov[j][j] > cov[best][best])) best = j;
    }
    used[best] = true;
    for (int d = 0; d < kN; ++d) basis.axes[k][d] = vectors[d][best];
  }
  // Re-orthonormalise in double (modified Gram-Schmidt, twice): the filter's lower bound needs
  // orthonormal axes, and the float rotations drift by up to ~1e-5.
  for (int pass = 0; pass < 2; ++pass) {
    for (int k = 0; k < FeatureBasis::kAxes; ++k) {
      for (int j = 0; j < k; ++j) {
        double dot = 0.0;
        for (int d = 0; d < kN; ++d) dot += basis.axes[k][d] * basis.axes[j][d];
        for (int d = 0; d < kN; ++d) basis.axes[k][d] -= dot * basis.axes[j][d];
      }
      double norm2 = 0.0;
      for (int d = 0; d < kN; ++d) norm2 += basis.axes[k][d] * basis.axes[k][d];
      const double inv = norm2 > 0.0 ? 1.0 / std::sqrt(norm2) : 0.0;  // 0: never rejects
      for (int d = 0; d < kN; ++d) basis.axes[k][d] *= inv;
    }
  }
  return true;
}

float project_features(std::span<const Feature33> features, const FeatureBasis& basis,
                       float* first, std::size_t stride) {
  float max_abs = 0.0f;
  for (std::size_t i = 0; i < features.size(); ++i) {
    float* out = first + i * stride;
    double c[kN];
    for (int d = 0; d < kN; ++d) c[d] = features[i][d] - basis.mean[d];
    for (int k = 0; k < FeatureBasis::kAxes; ++k) {
      double y = 0.0;
      for (int d = 0; d < kN; ++d) y += c[d] * basis.axes[k][d];
      out[k] = static_cast<float>(y);
      const float m = std::abs(out[k]);
      if (m > max_abs) max_abs = m;  // NaN never compares greater
    }
  }
  return max_abs;
}

}  // namespace v2xloc
