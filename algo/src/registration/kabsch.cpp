#include "v2xloc/algo/registration/kabsch.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace v2xloc {

void KabschAccumulator::reset() { *this = KabschAccumulator{}; }

void KabschAccumulator::add(const Vec3d& source, const Vec3d& target, double weight) {
  if (!(weight > 0.0) || !source.allFinite() || !target.allFinite() || !std::isfinite(weight)) {
    return;
  }
  if (count_ == 0) {
    origin_source_ = source;
    origin_target_ = target;
  }
  const Vec3d p = source - origin_source_;
  const Vec3d q = target - origin_target_;
  weight_sum_ += weight;
  source_sum_ += weight * p;
  target_sum_ += weight * q;
  cross_sum_ += (weight * p) * q.transpose();
  source_scatter_ += (weight * p) * p.transpose();
  ++count_;
}

RegistrationStatus KabschAccumulator::solve(Mat4d& transform, const KabschParams& params) const {
  if (count_ < 3 || !(weight_sum_ > 0.0)) return RegistrationStatus::kNotEnoughPoints;
  const Vec3d p_bar = source_sum_ / weight_sum_;
  const Vec3d q_bar = target_sum_ / weight_sum_;
  // Centred sums: sum w (p - p_bar)(q - q_bar)^T = sum w p q^T - W p_bar q_bar^T.
  const Mat3d h = cross_sum_ - weight_sum_ * p_bar * q_bar.transpose();
  const Mat3d source_cov = source_scatter_ - weight_sum_ * p_bar * p_bar.transpose();
  const double spread = source_cov.trace();
  if (!std::isfinite(spread) || !h.allFinite()) return RegistrationStatus::kDegenerate;
  if (spread <= params.min_spread) return RegistrationStatus::kDegenerate;

  const Eigen::JacobiSVD<Mat3d, Eigen::NoQRPreconditioner> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3d s = svd.singularValues();  // descending
  if (!(s(0) > 0.0) || s(1) <= params.min_singular_ratio * s(0)) {
    return RegistrationStatus::kDegenerate;
  }
  const Mat3d& u = svd.matrixU();
  const Mat3d& v = svd.matrixV();
  Mat3d d = Mat3d::Identity();
  if ((v * u.transpose()).determinant() < 0.0) d(2, 2) = -1.0;
  const Mat3d r = v * d * u.transpose();
  // Undo the origin shift: q = R (p_abs - o_s) + t_rel + o_t.
  const Vec3d t = q_bar + origin_target_ - r * (p_bar + origin_source_);
  if (!r.allFinite() || !t.allFinite()) return RegistrationStatus::kDegenerate;
  transform.setIdentity();
  transform.topLeftCorner<3, 3>() = r;
  transform.topRightCorner<3, 1>() = t;
  return RegistrationStatus::kOk;
}

RegistrationStatus kabsch_fit(std::span<const Vec3f> source, std::span<const Vec3f> target,
                              std::span<const double> weights, Mat4d& transform,
                              const KabschParams& params, std::uint32_t* skipped) {
  if (source.size() != target.size() || (!weights.empty() && weights.size() != source.size())) {
    return RegistrationStatus::kInvalidInput;
  }
  KabschAccumulator acc;
  std::uint32_t n_skipped = 0;
  for (std::size_t i = 0; i < source.size(); ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    const std::uint32_t before = acc.count();
    acc.add(source[i], target[i], w);
    if (acc.count() == before) ++n_skipped;
  }
  if (skipped != nullptr) *skipped = n_skipped;
  return acc.solve(transform, params);
}

}  // namespace v2xloc
