#include "host_sim/sensors/imu.hpp"

#include <algorithm>
#include <cmath>

namespace v2xloc::sim {
namespace {

constexpr double kGravity = 9.80665;
constexpr double kStep = 1e-3;

Eigen::Vector3d rotation_vector(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

Eigen::Vector3d draw3(Rng& rng, double sigma) {
  const double x = rng.gaussian(sigma), y = rng.gaussian(sigma), z = rng.gaussian(sigma);
  return {x, y, z};
}

bool clip(Eigen::Vector3d& v, double range) {
  bool clipped = false;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(v[k]) > range) {
      v[k] = std::copysign(range, v[k]);
      clipped = true;
    }
  }
  return clipped;
}

}  // namespace

ImuTruth imu_truth(const PoseAt& body_to_enu, const Eigen::Isometry3d& mount, double t) {
  const Eigen::Isometry3d before = body_to_enu(t - kStep) * mount;
  const Eigen::Isometry3d now = body_to_enu(t) * mount;
  const Eigen::Isometry3d after = body_to_enu(t + kStep) * mount;
  ImuTruth truth;
  // Body rate: the relative rotation over the two steps, in the sensor frame.
  truth.gyro = rotation_vector(before.linear().transpose() * after.linear()) / (2.0 * kStep);
  const Eigen::Vector3d accel_enu =
      (after.translation() - 2.0 * now.translation() + before.translation()) / (kStep * kStep);
  truth.accel = now.linear().transpose() * (accel_enu + Eigen::Vector3d(0.0, 0.0, kGravity));
  return truth;
}

ImuSimulator::ImuSimulator(const ImuConfig& config, std::uint64_t seed) : cfg_(config), rng_(seed) {
  // Per-run draws first, in a fixed order (the stream order is part of the recording's bytes).
  gyro_bias0_ = draw3(rng_, cfg_.gyro_turn_on_bias_sigma);
  accel_bias0_ = draw3(rng_, cfg_.accel_turn_on_bias_sigma);
  gyro_scale_ = Eigen::Vector3d::Ones() + draw3(rng_, cfg_.gyro_scale_sigma);
  accel_scale_ = Eigen::Vector3d::Ones() + draw3(rng_, cfg_.accel_scale_sigma);
  temperature0_ = 25.0 + rng_.gaussian(cfg_.temperature_start_sigma);
  gyro_walk_ = draw3(rng_, cfg_.gyro_bias_instability);  // the Gauss-Markov bias starts stationary
  accel_walk_ = draw3(rng_, cfg_.accel_bias_instability);
}

void ImuSimulator::advance_biases(double dt) {
  const double decay = std::exp(-dt / cfg_.bias_correlation_s);
  const double drive = std::sqrt(std::max(0.0, 1.0 - decay * decay));
  gyro_walk_ = decay * gyro_walk_ + draw3(rng_, cfg_.gyro_bias_instability * drive);
  accel_walk_ = decay * accel_walk_ + draw3(rng_, cfg_.accel_bias_instability * drive);
}

ImuMeasurement ImuSimulator::sample(const PoseAt& body_to_enu, double t) {
  if (started_) advance_biases(t - last_t_);
  started_ = true;
  last_t_ = t;
  ImuMeasurement m;
  m.t = t;
  m.truth = imu_truth(body_to_enu, cfg_.mount, t);
  m.temperature_c = temperature0_ + cfg_.warm_up_k * (1.0 - std::exp(-t / cfg_.warm_up_s));
  const double warm = m.temperature_c - temperature0_;
  m.gyro_bias = gyro_bias0_ + gyro_walk_ + Eigen::Vector3d::Constant(cfg_.gyro_bias_tempco * warm);
  m.accel_bias = accel_bias0_ + accel_walk_ + Eigen::Vector3d::Constant(cfg_.accel_bias_tempco * warm);
  // White noise per sample: the density over the sample interval (sigma = density * sqrt(rate)).
  const double root_rate = std::sqrt(cfg_.rate_hz);
  m.gyro = gyro_scale_.cwiseProduct(m.truth.gyro) + m.gyro_bias + draw3(rng_, cfg_.gyro_noise_density * root_rate);
  m.accel = accel_scale_.cwiseProduct(m.truth.accel) + m.accel_bias + draw3(rng_, cfg_.accel_noise_density * root_rate);
  m.gyro_saturated = clip(m.gyro, cfg_.gyro_range);
  m.accel_saturated = clip(m.accel, cfg_.accel_range);
  return m;
}

}  // namespace v2xloc::sim
