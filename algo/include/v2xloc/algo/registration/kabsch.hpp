// Weighted rigid fit (Kabsch 1976; Umeyama 1991 without scale): the R, t minimising
// sum_i w_i |R p_i + t - q_i|^2, from the SVD of the weighted cross-covariance
// H = sum_i w_i (p_i - p_bar)(q_i - q_bar)^T = U S V^T:  R = V diag(1, 1, d) U^T with
// d = sign(det(V U^T)) (no reflections), t = q_bar - R p_bar. All sums in double.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/registration/registration_result.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct KabschParams {
  // Degenerate if the second singular value of H is below this fraction of the largest
  // (collinear pairs leave one direction of rotation unobserved).
  double min_singular_ratio = 1e-9;
  // Degenerate if the total weighted spread (trace of the source scatter, m^2 * weight) is
  // below this (all points identical).
  double min_spread = 1e-12;
};

// Streaming accumulator: add pairs one by one (no storage), then solve. Coordinates are taken
// relative to the first point added, so large map coordinates do not cancel catastrophically.
class KabschAccumulator {
 public:
  void reset();
  void add(const Vec3d& source, const Vec3d& target, double weight = 1.0);
  void add(const Vec3f& source, const Vec3f& target, double weight = 1.0) {
    add(Vec3d(source.cast<double>()), Vec3d(target.cast<double>()), weight);
  }
  std::uint32_t count() const { return count_; }
  // kOk, kNotEnoughPoints (< 3 pairs or zero weight) or kDegenerate; transform is written
  // only on kOk.
  RegistrationStatus solve(Mat4d& transform, const KabschParams& params = {}) const;

 private:
  Vec3d origin_source_ = Vec3d::Zero();
  Vec3d origin_target_ = Vec3d::Zero();
  double weight_sum_ = 0.0;
  Vec3d source_sum_ = Vec3d::Zero();
  Vec3d target_sum_ = Vec3d::Zero();
  Mat3d cross_sum_ = Mat3d::Zero();    // sum w p q^T
  Mat3d source_scatter_ = Mat3d::Zero();  // sum w p p^T
  std::uint32_t count_ = 0;
};

// Convenience: pairs source[i] <-> target[i]; weights empty means all 1. NaN/Inf pairs and
// non-positive weights are skipped (counted in *skipped when given).
RegistrationStatus kabsch_fit(std::span<const Vec3f> source, std::span<const Vec3f> target,
                              std::span<const double> weights, Mat4d& transform,
                              const KabschParams& params = {}, std::uint32_t* skipped = nullptr);

}  // namespace v2xloc
