// Wheel speed and yaw rate as a vehicle's ESC/ABS unit puts them on CAN: white noise, a constant
// scale error (tyre radius), a yaw-rate bias that is constant plus a random walk (gyro drift), and
// quantization to the sensor's resolution.
#pragma once

#include <cstdint>

#include "host_sim/common/rng.hpp"

namespace v2xloc::sim {

struct VehicleSignalConfig {
  double speed_noise_mps = 0.03;           // white noise, 1 sigma
  double speed_scale_error_sigma = 0.005;  // tyre radius error drawn once per run (0.5 %)
  double speed_resolution_mps = 0.01;      // matches the CAN signal's factor
  double yaw_rate_noise_rps = 0.003;       // ~0.17 deg/s white noise
  double yaw_rate_bias_sigma_rps = 0.002;  // constant turn-on bias, drawn once per run
  double yaw_rate_bias_random_walk = 2e-4; // rad/s per sqrt(s)
  double yaw_rate_resolution_rps = 1e-4;   // matches the CAN signal's factor
  double standstill_speed_mps = 0.05;      // wheel pulses stop below this: reports exactly 0
};

struct VehicleSignals {
  double t = 0.0;
  double wheel_speed_mps = 0.0;
  double yaw_rate_rps = 0.0;
  bool speed_valid = true;
  bool yaw_rate_valid = true;
  std::uint8_t counter = 0;  // rolling 4-bit counter, incremented per sample
};

class VehicleSignalSimulator {
 public:
  VehicleSignalSimulator(const VehicleSignalConfig& config, std::uint64_t seed);
  VehicleSignals sample(double t, double true_speed_mps, double true_yaw_rate_rps);

  double speed_scale() const { return speed_scale_; }
  double yaw_rate_bias() const { return yaw_bias_; }

 private:

  VehicleSignalConfig cfg_;
  Rng rng_;
  double speed_scale_ = 1.0;
  double yaw_bias_ = 0.0;
  double last_t_ = 0.0;
  bool started_ = false;
  std::uint8_t counter_ = 0;
};

}  // namespace v2xloc::sim
