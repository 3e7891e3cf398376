// Whether a registration's own evidence supports it: ok, unreliable (a transform exists but the
// evidence does not back it) or failed (no usable transform). A pipeline's status says only
// that its stages ran; a wrong alignment of two clouds that overlap little converges just as
// well. The verdict reads what any result carries (status, fitness, inliers, convergence, the
// tilt of the source's up axis in the target) and, where the method has one, a runner-up in
// another basin (an ambiguity a single score hides). Each rule that fires sets one reason bit.
#pragma once

#include <cstdint>

#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/registration/registration_result.hpp"

namespace v2xloc {

enum class Verdict : std::uint8_t { kOk, kUnreliable, kFailed };

// Reason bits of a verdict (several may fire; 0 with kOk).
enum VerdictReason : std::uint32_t {
  kVerdictFailedStatus = 1u << 0,   // the registration returned no usable transform
  kVerdictLowFitness = 1u << 1,     // fitness < min_fitness
  kVerdictFewInliers = 1u << 2,     // inliers < min_inliers
  kVerdictTilted = 1u << 3,         // up axes more than max_tilt_deg apart (> 90: upside down)
  kVerdictAmbiguous = 1u << 4,      // a runner-up in another basin fits nearly as well
  kVerdictNotConverged = 1u << 5,   // stopped at its iteration cap below min_fitness_not_converged
};
inline constexpr std::uint32_t kVerdictReasonCount = 6;

struct VerdictParams {
  // [0-1] inlier share of the source at the final gate; below: unreliable (measured: wrong
  // vehicle/roadside alignments up to 0.32, correct ones 0.35-0.51 at a 1 m gate)
  double min_fitness = 0.33;
  std::uint32_t min_inliers = 500;  // [points] inlier correspondences at the final gate; below: unreliable
  double max_tilt_deg = 30.0;       // [deg] sensors are mounted upright (a roadside one pitched down a little): more is not physical
  double max_runner_up_ratio = 0.9; // [0-1] runner-up fitness / winner fitness at or above this: ambiguous
  // [0-1] an ICP stopped at its iteration cap (a limit cycle near the truth, or still sliding
  // off a wrong start) is trusted only at this fitness or above
  double min_fitness_not_converged = 0.45;
};

struct VerdictEvidence {
  RegistrationStatus status = RegistrationStatus::kInvalidInput;
  double fitness = 0.0;             // [0-1]
  std::uint32_t inliers = 0;
  double inlier_rmse = 0.0;         // [m]
  bool converged = false;
  double tilt_deg = 0.0;            // [deg] angle between R * z and z
  bool has_runner_up = false;
  double runner_up_fitness = 0.0;   // [0-1]
  double runner_up_ratio = 0.0;     // runner-up / winner fitness
  double runner_up_distance_m = 0.0;  // [m] between the two translations
  double runner_up_yaw_deg = 0.0;   // [deg] between the two headings
};

struct RegistrationVerdict {
  Verdict verdict = Verdict::kFailed;
  std::uint32_t reasons = kVerdictFailedStatus;  // VerdictReason bits
  VerdictEvidence evidence{};
};

// runner_up: the best result in another basin (nullptr or a non-ok status: none).
RegistrationVerdict judge_registration(const RegistrationResult& result, const RegistrationResult* runner_up,
                                       const VerdictParams& params = {});

inline const char* to_string(Verdict v) {
  switch (v) {
    case Verdict::kOk: return "ok";
    case Verdict::kUnreliable: return "unreliable";
    case Verdict::kFailed: return "failed";
  }
  return "unknown";
}

// Name of reason bit i (0 <= i < kVerdictReasonCount).
inline const char* verdict_reason_name(std::uint32_t i) {
  static constexpr const char* kNames[kVerdictReasonCount] = {"failed_status", "low_fitness", "few_inliers",
                                                              "tilted",        "ambiguous",   "not_converged"};
  return i < kVerdictReasonCount ? kNames[i] : "unknown";
}

}  // namespace v2xloc
