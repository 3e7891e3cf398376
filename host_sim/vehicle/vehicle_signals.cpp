#include "host_sim/vehicle/vehicle_signals.hpp"

#include <cmath>

namespace v2xloc::sim {
namespace {
double quantize(double value, double resolution) {
  return resolution > 0.0 ? std::nearbyint(value / resolution) * resolution : value;
}
}  // namespace

VehicleSignalSimulator::VehicleSignalSimulator(const VehicleSignalConfig& config, std::uint64_t seed)
    : cfg_(config), rng_(derive_seed(seed, {0x5645484943ull})) {  // "VEHIC"
  // Per-run constants: tyre radius error and the gyro's turn-on bias.
  speed_scale_ = 1.0 + rng_.gaussian(cfg_.speed_scale_error_sigma);
  yaw_bias_ = rng_.gaussian(cfg_.yaw_rate_bias_sigma_rps);
}

VehicleSignals VehicleSignalSimulator::sample(double t, double true_speed_mps, double true_yaw_rate_rps) {
  const double dt = started_ ? t - last_t_ : 0.0;
  started_ = true;
  last_t_ = t;
  if (dt > 0.0) yaw_bias_ += rng_.gaussian(cfg_.yaw_rate_bias_random_walk * std::sqrt(dt));

  VehicleSignals s;
  s.t = t;
  s.speed_valid = std::isfinite(true_speed_mps);
  s.yaw_rate_valid = std::isfinite(true_yaw_rate_rps);
  // Wheel-pulse speed: at standstill the pulse counter is silent, so the signal is exactly zero.
  double speed = 0.0;
  if (s.speed_valid && std::abs(true_speed_mps) >= cfg_.standstill_speed_mps) {
    speed = true_speed_mps * speed_scale_ + rng_.gaussian(cfg_.speed_noise_mps);
  }
  s.wheel_speed_mps = quantize(speed, cfg_.speed_resolution_mps);
  const double yaw = s.yaw_rate_valid ? true_yaw_rate_rps + yaw_bias_ + rng_.gaussian(cfg_.yaw_rate_noise_rps)
                                      : 0.0;
  s.yaw_rate_rps = quantize(yaw, cfg_.yaw_rate_resolution_rps);
  s.counter = counter_;
  counter_ = static_cast<std::uint8_t>((counter_ + 1u) & 0x0Fu);
  return s;
}

}  // namespace v2xloc::sim
