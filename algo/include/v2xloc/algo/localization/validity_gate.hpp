// Validity gate for registrations (Chao et al. 2025, Sec. 4, "valid registration"): per frame i,
// fitness f_i (inlier ratio, higher is better) and inlier RMSE r_i (lower is better) are compared
// with their local envelopes over a window of width w,
//   f_env_i = max_{|j-i| < w/2} f_j,   r_env_i = min_{|j-i| < w/2} r_j,
// and frame i is valid iff f_i >= f_env_i - d_f and r_i <= r_env_i + d_r.
// |j-i| < w/2 means a radius of (w-1)/2 frames (integer division): w = 11 -> j in [i-5, i+5].
//
// Two variants over the same ring buffer (capacity config::kGateMaxWindow frames):
//   FixedLagValidityGate  the paper's centred window; needs (w-1)/2 future frames, so push(frame i)
//                         returns the decision for frame i - (w-1)/2 (= i - w/2 for odd w).
//                         flush() decides the last frames with a truncated future window.
//   CausalValidityGate    the window [i-(2*radius), i] of the same 2*radius+1 frames, past only:
//                         an immediate decision, at the price of judging a frame only against
//                         its predecessors (a rising-quality ramp is accepted more readily).
// Failed registrations (ok == false) and non-finite metrics are invalid and excluded from the
// envelopes. At the sequence start the window is truncated to the frames that exist.
#pragma once

#include <cstddef>
#include <cstdint>

#include "v2xloc/algo/core/config.hpp"

namespace v2xloc {

struct ValidityGateParams {
  // w [frames]. 11 at 10 Hz = +-0.5 s: long enough that a bad frame has good neighbours to be
  // compared with, short enough that the envelope follows real changes of overlap as the ego
  // drives through the intersection. Clamped to [1, config::kGateMaxWindow];
  // an even w gives the same radius as w - 1 (strict inequality).
  std::size_t window = 11;
  // d_f [inlier ratio]. Fitness changes by a few percent between consecutive good frames (the
  // overlap changes slowly); a wrong RANSAC basin typically loses 10-50 %. 0.05 sits between.
  double fitness_margin = 0.05;
  // d_r [m]. Inlier RMSE of a correct alignment is set by sensor noise and voxel size and varies
  // by ~1 cm frame to frame; a misalignment inside the inlier threshold raises it by several cm.
  double rmse_margin = 0.02;
  // Optional absolute plausibility limits (defaults keep the paper's pure envelope test).
  double min_fitness = 0.0;
  double max_rmse = 1e30;  // [m]
};

struct GateSample {
  double fitness = 0.0;   // inlier ratio in [0, 1]
  double rmse = 0.0;      // inlier RMSE [m]
  bool ok = false;        // registration status ok (RegistrationResult::ok())
};

enum class GateReason : std::uint8_t {
  kValid,
  kRegistrationFailed,  // ok == false or non-finite metrics
  kLowFitness,          // f_i < f_env - d_f
  kHighRmse,            // r_i > r_env + d_r (checked after fitness)
  kImplausible,         // outside min_fitness / max_rmse
};

struct GateDecision {
  bool available = false;      // fixed-lag: false until enough future frames were seen
  std::uint64_t frame = 0;     // index (0-based, push order) of the frame decided
  bool valid = false;
  GateReason reason = GateReason::kRegistrationFailed;
  double fitness_envelope = 0.0;
  double rmse_envelope = 0.0;
};

struct GateCounters {
  std::uint64_t decided = 0;
  std::uint64_t valid = 0;
  std::uint64_t failed_registrations = 0;
  std::uint64_t low_fitness = 0;
  std::uint64_t high_rmse = 0;
  std::uint64_t implausible = 0;
};

// Shared ring buffer + envelope evaluation.
class ValidityGateBase {
 public:
  explicit ValidityGateBase(const ValidityGateParams& params = {});
  void reset();
  std::size_t radius() const { return radius_; }
  const ValidityGateParams& params() const { return params_; }
  const GateCounters& counters() const { return counters_; }

 protected:
  static constexpr std::size_t kCapacity = config::kGateMaxWindow;
  void store(const GateSample& sample);
  // Decides frame `frame` over the stored frames [first, last] (clamped to what is stored).
  GateDecision decide(std::uint64_t frame, std::uint64_t first, std::uint64_t last);
  const GateSample& at(std::uint64_t frame) const { return ring_[frame % kCapacity]; }

  ValidityGateParams params_;
  std::size_t radius_ = 0;
  GateSample ring_[kCapacity];
  std::uint64_t pushed_ = 0;  // frames stored so far; frame k lives at ring_[k % kCapacity]
  GateCounters counters_;
};

class FixedLagValidityGate : public ValidityGateBase {
 public:
  using ValidityGateBase::ValidityGateBase;
  // Stores frame pushed() and returns the decision for frame pushed() - radius() once available.
  GateDecision push(const GateSample& sample);
  // Decides the next undecided frame with a truncated future window (call until !available).
  GateDecision flush();
  std::size_t lag() const { return radius_; }  // decision delay [frames]
  void reset() { ValidityGateBase::reset(); next_decision_ = 0; }

 private:
  std::uint64_t next_decision_ = 0;
};

class CausalValidityGate : public ValidityGateBase {
 public:
  using ValidityGateBase::ValidityGateBase;
  // Stores and immediately decides the frame against the past 2*radius frames and itself.
  GateDecision push(const GateSample& sample);
};

}  // namespace v2xloc
