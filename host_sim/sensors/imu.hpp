// A MEMS IMU on the ego body (gyro + accelerometer), as an automotive-grade six-axis part of the
// Bosch BMI088 / SMI230 class measures: the true angular rate and specific force (gravity included)
// at the sensor's mount, from any smooth body trajectory (roll and pitch included), plus per axis a
// scale error and a turn-on bias drawn once per run, a bias that wanders (first-order Gauss-Markov
// at the bias instability), white noise at the noise density, a temperature drift of the bias, and
// clipping at the range. The figures and their sources: host_sim/README.md ("IMU").
// Deterministic: one seeded stream of its own.
#pragma once

#include <cstdint>
#include <functional>

#include <Eigen/Geometry>

#include "host_sim/common/rng.hpp"

namespace v2xloc::sim {

struct ImuConfig {
  double rate_hz = 200.0;
  double phase_s = 0.0013;                  // first sample after t = 0 (the sensor's own clock)
  Eigen::Isometry3d mount = Eigen::Isometry3d(Eigen::Translation3d(0.2, 0.0, 0.5));  // sensor in body (axes aligned)
  // Gyro [rad/s]
  double gyro_noise_density = 0.014 * M_PI / 180.0;      // 0.014 deg/s/sqrt(Hz)
  double gyro_turn_on_bias_sigma = 0.1 * M_PI / 180.0;   // residual after the zero-rate calibration
  double gyro_bias_instability = 2.0 / 3600.0 * M_PI / 180.0;  // 2 deg/h
  double gyro_bias_tempco = 0.015 * M_PI / 180.0;        // per K
  double gyro_scale_sigma = 0.005;
  double gyro_range = 300.0 * M_PI / 180.0;              // inside the report's +-327.67 deg/s
  // Accelerometer [m/s^2]
  double accel_noise_density = 175e-6 * 9.80665;         // 175 ug/sqrt(Hz)
  double accel_turn_on_bias_sigma = 20e-3 * 9.80665;     // 20 mg
  double accel_bias_instability = 40e-6 * 9.80665;       // 40 ug
  double accel_bias_tempco = 0.2e-3 * 9.80665;           // 0.2 mg per K
  double accel_scale_sigma = 0.005;
  double accel_range = 24.0 * 9.80665;
  double bias_correlation_s = 100.0;                     // Gauss-Markov time constant
  // Temperature [deg C]: start drawn around 25, then a warm-up towards +8 K (time constant 600 s).
  double temperature_start_sigma = 5.0, warm_up_k = 8.0, warm_up_s = 600.0;
};

struct ImuTruth {
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // [rad/s] body frame at the sensor
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // [m/s^2] specific force, sensor axes
};

struct ImuMeasurement {
  double t = 0.0;
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();
  double temperature_c = 25.0;
  bool gyro_saturated = false, accel_saturated = false;
  ImuTruth truth;
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();   // the error terms in this sample
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
};

// body_to_enu(t): the body pose in the local ENU frame (z up, gravity -z).
using PoseAt = std::function<Eigen::Isometry3d(double)>;

// Angular rate and specific force of a point fixed in the body, by central differences of the
// pose (h = 1 ms; exact to ~1e-8 for the simulator's analytic trajectories).
ImuTruth imu_truth(const PoseAt& body_to_enu, const Eigen::Isometry3d& mount, double t);

class ImuSimulator {
 public:
  ImuSimulator(const ImuConfig& config, std::uint64_t seed);
  // Samples in time order: t_k = phase + k / rate.
  ImuMeasurement sample(const PoseAt& body_to_enu, double t);
  double sample_time(std::int64_t k) const { return cfg_.phase_s + static_cast<double>(k) / cfg_.rate_hz; }

  const ImuConfig& config() const { return cfg_; }
  const Eigen::Vector3d& gyro_turn_on_bias() const { return gyro_bias0_; }
  const Eigen::Vector3d& accel_turn_on_bias() const { return accel_bias0_; }
  const Eigen::Vector3d& gyro_scale() const { return gyro_scale_; }
  const Eigen::Vector3d& accel_scale() const { return accel_scale_; }

 private:
  void advance_biases(double dt);

  ImuConfig cfg_;
  Rng rng_;
  Eigen::Vector3d gyro_bias0_, accel_bias0_, gyro_scale_, accel_scale_;
  Eigen::Vector3d gyro_walk_ = Eigen::Vector3d::Zero(), accel_walk_ = Eigen::Vector3d::Zero();
  double temperature0_ = 25.0;
  double last_t_ = 0.0;
  bool started_ = false;
};

}  // namespace v2xloc::sim
