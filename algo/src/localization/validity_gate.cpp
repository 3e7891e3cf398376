#include "v2xloc/algo/localization/validity_gate.hpp"

#include <cmath>

namespace v2xloc {

namespace {
bool usable(const GateSample& s) {
  return s.ok && std::isfinite(s.fitness) && std::isfinite(s.rmse);
}
}  // namespace

ValidityGateBase::ValidityGateBase(const ValidityGateParams& params) : params_(params) {
  std::size_t w = params_.window;
  if (w < 1) w = 1;
  if (w > kCapacity) w = kCapacity;
  params_.window = w;
  radius_ = (w - 1) / 2;  // |j - i| < w/2  <=>  |j - i| <= (w - 1) / 2 for integer offsets
}

void ValidityGateBase::reset() {
  pushed_ = 0;
  counters_ = {};
}

void ValidityGateBase::store(const GateSample& sample) {
  ring_[pushed_ % kCapacity] = sample;
  ++pushed_;
}

GateDecision ValidityGateBase::decide(std::uint64_t frame, std::uint64_t first, std::uint64_t last) {
  // Clamp the window to the frames still held in the ring and already pushed.
  const std::uint64_t oldest = pushed_ > kCapacity ? pushed_ - kCapacity : 0;
  if (first < oldest) first = oldest;
  if (last >= pushed_) last = pushed_ - 1;

  GateDecision d;
  d.available = true;
  d.frame = frame;
  const GateSample& self = at(frame);
  ++counters_.decided;
  if (!usable(self)) {
    d.reason = GateReason::kRegistrationFailed;
    ++counters_.failed_registrations;
    return d;
  }
  double f_env = self.fitness;
  double r_env = self.rmse;
  for (std::uint64_t j = first; j <= last; ++j) {  // <= 2 * radius + 1 <= kGateMaxWindow steps
    const GateSample& s = at(j);
    if (!usable(s)) continue;  // failed registrations do not shape the envelope
    if (s.fitness > f_env) f_env = s.fitness;
    if (s.rmse < r_env) r_env = s.rmse;
  }
  d.fitness_envelope = f_env;
  d.rmse_envelope = r_env;
  if (self.fitness < f_env - params_.fitness_margin) {
    d.reason = GateReason::kLowFitness;
    ++counters_.low_fitness;
  } else if (self.rmse > r_env + params_.rmse_margin) {
    d.reason = GateReason::kHighRmse;
    ++counters_.high_rmse;
  } else if (self.fitness < params_.min_fitness || self.rmse > params_.max_rmse) {
    d.reason = GateReason::kImplausible;
    ++counters_.implausible;
  } else {
    d.reason = GateReason::kValid;
    d.valid = true;
    ++counters_.valid;
  }
  return d;
}

GateDecision FixedLagValidityGate::push(const GateSample& sample) {
  store(sample);
  const std::uint64_t newest = pushed_ - 1;
  if (newest < next_decision_ + radius_) return {};  // future half-window not complete yet
  const std::uint64_t frame = next_decision_++;
  const std::uint64_t first = frame >= radius_ ? frame - radius_ : 0;
  return decide(frame, first, frame + radius_);
}

GateDecision FixedLagValidityGate::flush() {
  if (next_decision_ >= pushed_) return {};
  const std::uint64_t frame = next_decision_++;
  const std::uint64_t first = frame >= radius_ ? frame - radius_ : 0;
  return decide(frame, first, frame + radius_);  // decide() clamps to the last pushed frame
}

GateDecision CausalValidityGate::push(const GateSample& sample) {
  store(sample);
  const std::uint64_t frame = pushed_ - 1;
  const std::uint64_t span = 2 * static_cast<std::uint64_t>(radius_);
  const std::uint64_t first = frame >= span ? frame - span : 0;
  return decide(frame, first, frame);
}

}  // namespace v2xloc
