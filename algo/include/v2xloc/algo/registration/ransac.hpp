// RANSAC on putative (feature) correspondences, Open3D 0.16 RegistrationRANSACBasedOnCorrespondence
// semantics (Fischler & Bolles 1981; pre-rejection after Buch et al. 2013 / Open3D checkers):
//   1. draw 3 distinct correspondences with the seeded PCG32 (deterministic),
//   2. edge-length checker: every pair of sampled points has |ps_i - ps_j| and |pt_i - pt_j|
//      within a factor `edge_length_similarity` of each other (CorrespondenceCheckerBasedOnEdgeLength),
//   3. Kabsch fit of the 3 pairs; distance checker: every sampled pair lies within
//      `distance_check_threshold` after the fit (CorrespondenceCheckerBasedOnDistance),
//   4. validation: the fraction of ALL correspondences within max_correspondence_distance (the
//      "correspondence fitness"); best = higher fitness, ties broken by lower RMSE,
//   5. stop at max_iterations samples, max_validations validations, or when the adaptive bound
//      log(1 - confidence) / log(1 - fitness^3) (RANSACConvergenceCriteria) is reached,
//   6. refit with Kabsch on all correspondence inliers of the best hypothesis (repeated while the
//      inlier set grows, at most refit_rounds times), then evaluate against the target k-d tree:
//      fitness / RMSE / information with Open3D's meaning over the source points.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/registration/correspondences.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/registration/registration_result.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct RansacCriteria {
  std::uint32_t max_iterations = config::kRansacMaxIterations;    // samples; clamped to the config cap
  std::uint32_t max_validations = config::kRansacMaxValidations;  // hypotheses scored; clamped too
  double confidence = 0.999;                                      // Open3D default
};

// Optional prior on the hypothesis (a vehicle on a road: GNSS region, near-level attitude). A
// hypothesis outside it is rejected before scoring, like Open3D's checkers: in a symmetric
// street canyon the best FPFH consensus is often the mirrored pose, which only a prior excludes.
struct RansacPosePrior {
  bool enabled = false;
  Vec3d center = Vec3d::Zero();     // expected translation of the hypothesis [m]
  double max_horizontal = 1e9;      // [m] allowed |t_xy - center_xy|
  double max_vertical = 1e9;        // [m] allowed |t_z - center_z|
  double max_tilt = 3.2;            // [rad] allowed angle between R * z and z (roll/pitch)
};

struct RansacParams {
  RansacPosePrior prior{};
  double max_correspondence_distance = 0.075;  // [m] inlier distance (Open3D tutorial: 1.5 voxel)
  double edge_length_similarity = 0.9;         // 0 disables the edge-length checker
  double distance_check_threshold = 0.0;       // [m]; 0: = max_correspondence_distance; < 0: off
  std::uint32_t refit_rounds = 3;
  std::uint64_t seed = 0x5eed;                 // PCG32 seed: same seed, same result
  RansacCriteria criteria{};
};

struct RansacResult {
  RegistrationResult registration;           // fitness etc. over the source cloud (Open3D meaning)
  double correspondence_fitness = 0.0;       // inlier fraction of the correspondences (best)
  std::uint32_t correspondence_inliers = 0;  // after the refit
  std::uint32_t validations = 0;             // hypotheses that passed the checkers
  std::uint32_t rejected_edge_length = 0;
  std::uint32_t rejected_distance = 0;
  std::uint32_t rejected_prior = 0;
  std::uint32_t degenerate_samples = 0;      // Kabsch refused the sample (collinear / repeated)
  std::uint32_t invalid_correspondences = 0; // out-of-range indices or non-finite points, skipped
  std::uint32_t adaptive_bound = 0;          // final confidence-derived iteration bound
};

// source/target: the (downsampled) clouds the correspondence indices refer to; target_tree is
// built over `target`. Status: kOk, kNoCorrespondences (< 3 usable), kInvalidInput,
// kDidNotConverge (no hypothesis passed the checkers; transform identity).
RansacResult ransac(std::span<const Vec3f> source, std::span<const Vec3f> target,
                    std::span<const Correspondence> correspondences,
                    const KdTree<Vec3f>& target_tree, const RansacParams& params);

}  // namespace v2xloc
