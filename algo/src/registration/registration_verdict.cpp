#include "v2xloc/algo/registration/registration_verdict.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc {
namespace {

constexpr double kDegPerRad = 180.0 / det::kPi;

// Angle between the source's up axis carried into the target (third column of R) and z.
double tilt_deg(const Mat4d& t) {
  const double c = t(2, 2);
  const double s = std::sqrt(t(0, 2) * t(0, 2) + t(1, 2) * t(1, 2));
  return det::atan2(s, c) * kDegPerRad;
}

double yaw_of(const Mat4d& t) { return det::atan2(t(1, 0), t(0, 0)); }

}  // namespace

RegistrationVerdict judge_registration(const RegistrationResult& result, const RegistrationResult* runner_up,
                                       const VerdictParams& params) {
  RegistrationVerdict v;
  VerdictEvidence& e = v.evidence;
  e.status = result.status;
  e.fitness = result.fitness;
  e.inliers = result.inliers;
  e.inlier_rmse = result.inlier_rmse;
  e.converged = result.converged;
  // A truncated input still yields a computed transform: judged on its evidence like an ok one.
  const bool usable = (result.status == RegistrationStatus::kOk || result.status == RegistrationStatus::kCapacityExceeded) &&
                      result.transform.allFinite();
  if (!usable) return v;  // kFailed, kVerdictFailedStatus
  e.tilt_deg = tilt_deg(result.transform);
  std::uint32_t reasons = 0;
  if (!(result.fitness >= params.min_fitness)) reasons |= kVerdictLowFitness;
  if (result.inliers < params.min_inliers) reasons |= kVerdictFewInliers;
  if (!(e.tilt_deg <= params.max_tilt_deg)) reasons |= kVerdictTilted;
  if (!result.converged && !(result.fitness >= params.min_fitness_not_converged)) reasons |= kVerdictNotConverged;
  if (runner_up != nullptr && runner_up->ok()) {
    e.has_runner_up = true;
    e.runner_up_fitness = runner_up->fitness;
    e.runner_up_ratio = result.fitness > 0.0 ? runner_up->fitness / result.fitness : 1.0;
    e.runner_up_distance_m = (runner_up->transform.topRightCorner<3, 1>() - result.transform.topRightCorner<3, 1>()).norm();
    e.runner_up_yaw_deg = std::abs(det::wrap_pi(yaw_of(runner_up->transform) - yaw_of(result.transform))) * kDegPerRad;
    if (e.runner_up_ratio >= params.max_runner_up_ratio) reasons |= kVerdictAmbiguous;
  }
  v.reasons = reasons;
  v.verdict = reasons == 0 ? Verdict::kOk : Verdict::kUnreliable;
  return v;
}

}  // namespace v2xloc
