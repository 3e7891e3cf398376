#include "host_sim/vehicle/vehicle_signals.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace v2xloc::sim {
namespace {

TEST(VehicleSignals, NoiseBiasQuantization) {
  VehicleSignalConfig cfg;
  VehicleSignalSimulator sim(cfg, 3);
  double speed_err = 0.0, yaw_err = 0.0;
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    const VehicleSignals s = sim.sample(i * 0.02, 10.0, 0.1);
    EXPECT_EQ(s.counter, i % 16);
    // Quantized to the CAN resolution.
    EXPECT_NEAR(s.wheel_speed_mps / cfg.speed_resolution_mps, std::round(s.wheel_speed_mps / cfg.speed_resolution_mps), 1e-6);
    EXPECT_NEAR(s.yaw_rate_rps / cfg.yaw_rate_resolution_rps, std::round(s.yaw_rate_rps / cfg.yaw_rate_resolution_rps), 1e-6);
    speed_err += s.wheel_speed_mps - 10.0;
    yaw_err += s.yaw_rate_rps - 0.1;
  }
  // Mean errors follow the per-run scale error and bias, not zero.
  EXPECT_NEAR(speed_err / n, 10.0 * (sim.speed_scale() - 1.0), 0.01);
  EXPECT_GT(std::abs(yaw_err / n), 1e-5);
  EXPECT_LT(std::abs(yaw_err / n), 0.01);
  EXPECT_EQ(sim.sample(41.0, 0.0, 0.0).wheel_speed_mps, 0.0);  // standstill: exactly zero
}

TEST(VehicleSignals, DeterministicPerSeed) {
  VehicleSignalSimulator a(VehicleSignalConfig{}, 9), b(VehicleSignalConfig{}, 9), c(VehicleSignalConfig{}, 10);
  bool differs = false;
  for (int i = 0; i < 100; ++i) {
    const auto sa = a.sample(i * 0.1, 5.0, -0.2), sb = b.sample(i * 0.1, 5.0, -0.2), sc = c.sample(i * 0.1, 5.0, -0.2);
    EXPECT_EQ(sa.wheel_speed_mps, sb.wheel_speed_mps);
    EXPECT_EQ(sa.yaw_rate_rps, sb.yaw_rate_rps);
    differs |= sa.yaw_rate_rps != sc.yaw_rate_rps;
  }
  EXPECT_TRUE(differs);
}

}  // namespace
}  // namespace v2xloc::sim
