// The simulator's IMU (host_sim/sensors/imu.hpp) against its ground truth: rates and specific
// force of the mount point from the trajectory (a turn, a tilted body), the error model's
// statistics within its figures, and its HID reports (host_sim/recording/imu_reports.hpp) decoding
// through the firmware's IMU decoder to the sampled values at the sample times.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "firmware/wire/imu_input_decoder.hpp"
#include "hal/hid_imu_report.hpp"
#include "host_sim/recording/imu_reports.hpp"
#include "host_sim/scenario/scenario.hpp"
#include "host_sim/sensors/imu.hpp"

namespace v2xloc::sim {
namespace {

constexpr double kG = 9.80665;
constexpr double kDeg = M_PI / 180.0;

double stddev(const std::vector<double>& v) {
  double mean = 0.0, sq = 0.0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  for (double x : v) sq += (x - mean) * (x - mean);
  return std::sqrt(sq / static_cast<double>(v.size() - 1));
}

TEST(SimImu, TruthIsTheMountPointsRateAndSpecificForceInATurn) {
  const Scenario sc = make_scenario(3);  // the left turn
  const PoseAt pose = [&sc](double t) { return sc.ego.body_to_enu(t); };
  const ImuConfig cfg;
  const Eigen::Vector3d r = cfg.mount.translation();
  int turning = 0;
  for (double t = 0.5; t < sc.duration - 0.5; t += 0.25) {
    const VehicleState s = sc.ego.state(t);
    const ImuTruth truth = imu_truth(pose, cfg.mount, t);
    const double h = 1e-4;
    const double alpha = (sc.ego.state(t + h).yaw_rate - sc.ego.state(t - h).yaw_rate) / (2 * h);
    EXPECT_NEAR(truth.gyro.z(), s.yaw_rate, 1e-6) << t;
    EXPECT_NEAR(truth.gyro.x(), 0.0, 1e-9);
    EXPECT_NEAR(truth.gyro.y(), 0.0, 1e-9);
    // Flat road: a_x = dv/dt - w^2 r_x, a_y = v w + alpha r_x, a_z = g (no roll or pitch).
    EXPECT_NEAR(truth.accel.x(), s.accel - s.yaw_rate * s.yaw_rate * r.x(), 2e-3) << t;
    EXPECT_NEAR(truth.accel.y(), s.speed * s.yaw_rate + alpha * r.x(), 2e-3) << t;
    EXPECT_NEAR(truth.accel.z(), kG, 1e-6);
    if (std::abs(s.yaw_rate) > 0.3) ++turning;
  }
  EXPECT_GT(turning, 4);  // not a vacuous check: the turn is in there
}

TEST(SimImu, ATiltedBodyAtRestSensesGravityInItsAxes) {
  const Eigen::Isometry3d tilted(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(-0.05, Eigen::Vector3d::UnitX()));
  const PoseAt pose = [&tilted](double) { return tilted; };
  const ImuTruth truth = imu_truth(pose, ImuConfig{}.mount, 3.0);
  const Eigen::Vector3d expected = tilted.linear().transpose() * Eigen::Vector3d(0, 0, kG);
  EXPECT_LT((truth.accel - expected).norm(), 1e-6);
  EXPECT_LT(truth.gyro.norm(), 1e-12);
  EXPECT_GT(std::abs(truth.accel.x()), 0.9);  // pitched nose down 0.1 rad: ~0.98 m/s^2 forward
}

TEST(SimImu, ErrorsFollowTheModelsFigures) {
  const ImuConfig cfg;
  const PoseAt rest = [](double) { return Eigen::Isometry3d::Identity(); };
  // Turn-on bias and scale: drawn once per run, over 400 runs their spread is the configured sigma.
  std::vector<double> bias_z, scale_z, accel_bias_x;
  for (std::uint64_t seed = 1; seed <= 400; ++seed) {
    ImuSimulator imu(cfg, seed);
    bias_z.push_back(imu.gyro_turn_on_bias().z());
    scale_z.push_back(imu.gyro_scale().z());
    accel_bias_x.push_back(imu.accel_turn_on_bias().x());
  }
  EXPECT_NEAR(stddev(bias_z) / cfg.gyro_turn_on_bias_sigma, 1.0, 0.15);
  EXPECT_NEAR(stddev(scale_z) / cfg.gyro_scale_sigma, 1.0, 0.15);
  EXPECT_NEAR(stddev(accel_bias_x) / cfg.accel_turn_on_bias_sigma, 1.0, 0.15);
  // One 60-s run at rest: white noise = density x sqrt(rate); the wandering bias stays within a few
  // sigma of the bias instability around the turn-on bias plus the temperature drift.
  ImuSimulator imu(cfg, 7);
  std::vector<double> gyro_noise, accel_noise;
  double worst_wander = 0.0;
  for (std::int64_t k = 0; imu.sample_time(k) < 60.0; ++k) {
    const ImuMeasurement m = imu.sample(rest, imu.sample_time(k));
    gyro_noise.push_back(m.gyro.z() - m.gyro_bias.z());
    accel_noise.push_back(m.accel.x() - m.accel_bias.x());
    const double drift = cfg.gyro_bias_tempco * (cfg.warm_up_k * (1.0 - std::exp(-m.t / cfg.warm_up_s)));
    worst_wander = std::max(worst_wander, std::abs(m.gyro_bias.z() - imu.gyro_turn_on_bias().z() - drift));
    EXPECT_FALSE(m.gyro_saturated || m.accel_saturated);
  }
  const double root_rate = std::sqrt(cfg.rate_hz);
  EXPECT_NEAR(stddev(gyro_noise) / (cfg.gyro_noise_density * root_rate), 1.0, 0.05);
  EXPECT_NEAR(stddev(accel_noise) / (cfg.accel_noise_density * root_rate), 1.0, 0.05);
  EXPECT_LT(worst_wander, 5.0 * cfg.gyro_bias_instability);
  EXPECT_GT(worst_wander, 0.0);
}

TEST(SimImu, ReportsDecodeToTheSamplesAtTheirTimes) {
  const Scenario sc = make_scenario(3);
  const PoseAt pose = [&sc](double t) { return sc.ego.body_to_enu(t); };
  constexpr double kOrigin = 1700000000.0;
  const ImuReportStream stream = simulate_imu_reports(ImuConfig{}, 42, pose, 3.0, kOrigin);
  ASSERT_EQ(stream.reports.size(), 600u);  // 200 Hz for 3 s
  const ImuReportStream again = simulate_imu_reports(ImuConfig{}, 42, pose, 3.0, kOrigin);
  for (std::size_t i = 0; i < stream.reports.size(); ++i) ASSERT_EQ(stream.reports[i].bytes, again.reports[i].bytes);

  const std::int64_t epoch_ns = static_cast<std::int64_t>(kOrigin) * 1'000'000'000;
  auto decoder = std::make_unique<firmware::ImuInputDecoder>(epoch_ns);
  for (std::size_t i = 0; i < stream.reports.size(); ++i) {
    const hal::HidScriptLine& r = stream.reports[i];
    const ImuMeasurement& m = stream.measurements[i];
    // Received at the next 1-ms USB frame after the sample.
    EXPECT_GT(r.timestamp_ns, std::llround(m.t * 1e9));
    EXPECT_LE(r.timestamp_ns, std::llround(m.t * 1e9) + 1'000'000);
    ASSERT_EQ(decoder->decode(std::span<const std::uint8_t>(r.bytes.data(), r.size), epoch_ns + r.timestamp_ns),
              firmware::ImuReportKind::kSample);
    ImuInput s;
    ASSERT_TRUE(decoder->take(s));
    EXPECT_NEAR(s.t, m.t, 0.5e-6);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(s.gyro[k], m.gyro[k], 0.5 * hal::hid_imu::kGyroDegPerSecondPerLsb * kDeg + 1e-12);
      EXPECT_NEAR(s.accel[k], m.accel[k], 0.5 * hal::hid_imu::kAccelGPerLsb * kG + 1e-12);
    }
  }
  EXPECT_EQ(decoder->counters().lost, 0u);
  EXPECT_EQ(decoder->counters().unsynced, 0u);
}

}  // namespace
}  // namespace v2xloc::sim
