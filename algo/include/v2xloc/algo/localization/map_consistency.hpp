// Consistency of a candidate map cloud with a reference (other sources' stored points), where
// they overlap: reference points that fall in the candidate's occupied cells are registered onto
// the candidate's local planes by a translation-only point-to-plane ICP. The estimated offset is
// the candidate's displacement from where the reference puts the same surfaces (a 0.25 m shift
// shows as ~0.25 m, not as a few percent of inliers); directions no matched normal constrains
// (ground only) are not estimated, and the pair then cannot be checked. Shifts beyond the ICP's
// reach: a coarse horizontal grid search of where the reference best covers the candidate's cells
// gives the ICP a second start; the better-matching solution is the offset.
// Work is bounded: at most config::kMapCheckMaxExamined reference points looked up, at most
// config::kMapCheckMaxPoints matched, 2 x config::kMapCheckMaxIterations iterations, and
// (2 kMapCheckSearchSteps + 1)^2 grid offsets x kMapCheckSearchPoints lookups (even strides:
// the same points every time for the same input).
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/localization/map_fusion_params.hpp"
#include "v2xloc/algo/localization/map_plane_cells.hpp"

namespace v2xloc {

enum class MapCheckVerdict : std::uint8_t {
  kUncheckable,  // too little overlap, or a direction no surface in the overlap constrains
  kAgree,
  kDisagree,     // offset above the limit, or too few inliers where they overlap
};

struct MapCheckResult {
  MapCheckVerdict verdict = MapCheckVerdict::kUncheckable;
  std::uint32_t overlap_points = 0;   // examined reference points in the candidate's cells
  std::uint32_t sampled_points = 0;   // of those, the ICP's points (at most kMapCheckMaxPoints)
  std::uint32_t sampled_upright = 0;  // of those, in the candidate's cells that are not level
  std::uint32_t matched_points = 0;   // of the sampled ones, matched to a plane at the final offset
  std::uint32_t matched_upright = 0;  // of the sampled upright ones, matched
  double inlier_fraction = 0.0;       // within inlier_distance, over matched
  double weakest_constraint = 0.0;    // smallest eigenvalue of sum(w n n^T) / sum(w)
  Vec3d offset = Vec3d::Zero();       // [m] candidate minus reference (unobserved directions 0)
  std::uint32_t iterations = 0;       // ICP iterations (both runs when searched far)
  bool far = false;                   // the offset came from the far search's start
};

class MapConsistencyCheck {
 public:
  // Builds the candidate's planes (once per candidate); returns cells dropped (table full).
  std::uint32_t set_candidate(std::span<const Vec3f> candidate, const MapFusionParams& params);
  // Checks the candidate against the reference: the union of `ranges` (each a source's points).
  // max_offset [m]: the disagreement limit for this candidate's role.
  MapCheckResult check(std::span<const std::span<const Vec3f>> ranges, double max_offset);

 private:
  struct Normals {
    Mat3d a = Mat3d::Zero();  // sum w n n^T
    Vec3d b = Vec3d::Zero();  // sum w n r
    double weight = 0.0;  // sum of the robust weights
    std::uint32_t matched = 0;
    std::uint32_t inliers = 0;
  };
  void sample_overlap(std::span<const std::span<const Vec3f>> ranges, MapCheckResult& r);
  void take_even(std::uint8_t flag, std::size_t count, std::size_t keep);
  Normals accumulate(const Vec3d& offset, double gate, std::uint32_t* matched_upright = nullptr);
  Vec3d refine(const Vec3d& start, std::uint32_t& iterations);
  std::uint32_t occupied_hits(const Vec3d& offset) const;
  bool far_search(Vec3d& start) const;
  // One Gauss-Newton step in the constrained directions; returns the weakest eigenvalue / matched.
  double solve_step(const Normals& n, Vec3d& step) const;
  MapCheckVerdict verdict(const MapCheckResult& r, bool observed, double max_offset) const;

  MapFusionParams params_;
  MapPlaneCells planes_;
  FixedVector<Vec3f, config::kMapCheckMaxExamined> overlap_;  // examined points inside the candidate
  FixedVector<std::uint8_t, config::kMapCheckMaxExamined> level_;  // 1: in a level cell (ground)
  FixedVector<Vec3f, config::kMapCheckMaxPoints> matched_;    // the ICP's points (even stride)
  FixedVector<Vec3f, config::kMapCheckSearchPoints> search_;  // examined points, even stride
  std::size_t upright_ = 0;  // matched_[0, upright_) lie in upright (not level) candidate cells
};

}  // namespace v2xloc
