// Feature correspondences: for every source feature its nearest target feature in 33-D
// (Euclidean, exact up to the k-d tree visit cap), as in Open3D 0.16
// RegistrationRANSACBasedOnFeatureMatching. With the mutual filter a pair (i, j) is kept only
// if i is also the nearest source feature of j; if fewer than min_mutual pairs survive, the
// one-way set is returned instead (Open3D: ransac_n * 3) and fell_back is set.
// Output order: ascending source index. Ties in distance go to the lower index (deterministic).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct Correspondence {
  std::uint32_t source;
  std::uint32_t target;
};

// Query-side projections for the trees' exact pre-filter (KdTree::set_projections): feature i
// of each set at <set>[i * stride]. Null pointers: queries run without the filter.
struct FeatureProjections {
  const float* source = nullptr;
  const float* target = nullptr;
  std::size_t stride = 0;
};

struct CorrespondenceParams {
  bool mutual_filter = false;
  std::size_t min_mutual = 9;   // Open3D: 3 * ransac_n with ransac_n = 3
  FeatureProjections projections{};  // speed only: results are the same without
};

// Principal axes of two feature sets (the covariance of every sample_stride-th feature of both,
// cyclic Jacobi: deterministic) for the projection pre-filter. Any orthonormal basis keeps the
// searches exact; the principal one rejects the most candidates (FPFH: the top 8 of 33 axes
// hold ~90 % of the variance). scratch: >= 2 * kFpfhBins entries (two 33x33 float matrices;
// e.g. the SPFH scratch once the features exist); false if smaller (basis left unchanged).
struct FeatureBasis {
  static constexpr int kAxes = KdTree<Feature33>::kProjectionDim;
  double mean[kFpfhBins];
  double axes[kAxes][kFpfhBins];
};
bool compute_feature_basis(std::span<const Feature33> a, std::span<const Feature33> b,
                           std::size_t sample_stride, std::span<Feature33> scratch,
                           FeatureBasis& basis);
// Projection of feature i (minus the mean) onto the axes, written to first[i * stride + k];
// returns the largest |coordinate| (for KdTree::set_projections). Non-finite features give
// non-finite projections, which never reject anything.
float project_features(std::span<const Feature33> features, const FeatureBasis& basis,
                       float* first, std::size_t stride);

enum class CorrespondenceStatus : std::uint8_t {
  kOk,
  kEmptyInput,      // no source features or an empty target tree
  kInvalidStorage,  // mutual filter without a source tree or with too little scratch
  kNoMatches,       // every query failed (non-finite features)
};

struct CorrespondenceResult {
  CorrespondenceStatus status = CorrespondenceStatus::kEmptyInput;
  std::uint32_t count = 0;
  std::uint32_t truncated = 0;          // matches beyond out's capacity
  std::uint32_t no_match = 0;           // source features with no neighbour (non-finite)
  std::uint32_t mutual_rejected = 0;
  bool fell_back = false;               // mutual set too small, one-way set returned
  KdQueryCounters search;
};

// source_features: the features of the source cloud (index = source point index).
// The mutual check asks the source tree only "is any source closer to j than i?" for the best
// candidate i of each matched target j (bounded, first-hit exit), not a full nearest search.
// target_tree: built over the target features. For the mutual filter: source_tree built over
// source_features and scratch with >= target_tree.points().size() entries (candidate source of
// each target; overwritten), else both may be empty/unused.
CorrespondenceResult match_features(std::span<const Feature33> source_features,
                                    const KdTree<Feature33>& target_tree,
                                    const CorrespondenceParams& params,
                                    BoundedVector<Correspondence>& out,
                                    const KdTree<Feature33>* source_tree = nullptr,
                                    std::span<std::uint32_t> scratch = {});

}  // namespace v2xloc
