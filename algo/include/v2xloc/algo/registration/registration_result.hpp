// The result every registration stage (Kabsch, RANSAC, ICP, the pipeline facade) returns.
// Conventions follow Open3D's RegistrationResult so numbers are comparable with it:
//   transform    p_target = transform * p_source (homogeneous, row-major meaning of Mat4d).
//   fitness      inlier correspondences / number of (valid) source points, in [0, 1].
//   inlier_rmse  sqrt(mean squared distance) over inlier correspondences; 0 when there are none.
//   information  6x6 information matrix of the final alignment in Open3D's
//                GetInformationMatrixFromPointClouds meaning: sum over inlier correspondences of
//                J^T J with J = [ -[q]x | I3 ] evaluated at the target point q, parameter order
//                (rx, ry, rz, tx, ty, tz) (a small left-multiplied twist). Unitless counts of
//                m^2 / m; scale by 1/sigma^2 of the point noise to get an inverse covariance.
#pragma once

#include <cstdint>

#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

enum class RegistrationStatus : std::uint8_t {
  kOk = 0,
  kInvalidInput,        // bad parameters (non-positive distances, null target tree, ...)
  kNotEnoughPoints,     // fewer valid points than the method needs (after NaN/Inf removal)
  kNoCorrespondences,   // no correspondence within the max distance / no feature matches
  kDegenerate,          // geometry does not constrain all 6 DoF (collinear, identical, planar)
  kDidNotConverge,      // RANSAC: no hypothesis survived; ICP: iteration cap hit (result usable)
  kCapacityExceeded,    // input truncated to a buffer capacity (result still computed)
};

inline const char* to_string(RegistrationStatus status) {
  switch (status) {
    case RegistrationStatus::kOk: return "ok";
    case RegistrationStatus::kInvalidInput: return "invalid_input";
    case RegistrationStatus::kNotEnoughPoints: return "not_enough_points";
    case RegistrationStatus::kNoCorrespondences: return "no_correspondences";
    case RegistrationStatus::kDegenerate: return "degenerate";
    case RegistrationStatus::kDidNotConverge: return "did_not_converge";
    case RegistrationStatus::kCapacityExceeded: return "capacity_exceeded";
  }
  return "unknown";
}

struct RegistrationResult {
  RegistrationStatus status = RegistrationStatus::kInvalidInput;
  Mat4d transform = Mat4d::Identity();     // p_target = transform * p_source
  double fitness = 0.0;                    // inliers / valid source points
  double inlier_rmse = 0.0;                // [m], over inliers, 0 when none
  std::uint32_t iterations = 0;            // ICP: Gauss-Newton steps; RANSAC: samples drawn
  std::uint32_t inliers = 0;               // inlier correspondences of the final transform
  bool converged = false;                  // a convergence criterion (not a cap) ended the loop
  Mat6d information = Mat6d::Zero();       // see header comment
  // Point-to-plane ICP: the share of the translational constraint (sum of w n n^T over the final
  // pass) along its weakest horizontal direction, lambda_min(xy block) / trace, in [0, 0.5]. Near
  // 0 the matched surfaces (facades across a straight street, the road) leave the pose free
  // along one horizontal direction: an along-street alias fits as well. 0 for other methods.
  double horizontal_constraint = 0.0;
  std::uint32_t nonfinite_dropped = 0;     // NaN/Inf input points skipped
  std::uint32_t overflow_dropped = 0;      // inputs beyond a capacity, truncated
  std::uint32_t search_truncated = 0;      // k-d tree queries that hit the node-visit cap
  std::uint64_t node_visits = 0;           // ICP / evaluation: k-d tree nodes the queries visited (their work)

  bool ok() const { return status == RegistrationStatus::kOk; }
};

}  // namespace v2xloc
