// The IMU in the filter, on synthetic streams: a vehicle driving curves with a known yaw rate, the
// CAN wheel speed and yaw rate at 100 Hz (noise, bias and bias walk as the simulator's), a MEMS gyro
// at 200 Hz (the class's noise, a turn-on bias), registrations at 10 Hz; the intake's checks, the
// gyro bias's convergence, the faults (dropout, stuck axis, bias step), the benefit when the
// registrations stop for 3 s, and the filter without IMU samples (the gyro bias never touches
// the other states).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/imu_intake.hpp"
#include "v2xloc/algo/localization/pose_filter.hpp"

namespace v2xloc {
namespace {

namespace idx = ekf_index;

constexpr double kImuPeriod = 0.005;  // 200 Hz

// ---- The intake ----

ImuInput sample(double t, double gz) {
  ImuInput in;
  in.t = t;
  in.gyro[2] = gz;
  in.gyro[0] = 1e-3 * std::sin(1000.0 * t);  // live axes: never the same value twice
  in.gyro[1] = 1e-3 * std::cos(1000.0 * t);
  in.accel[0] = 0.1 * std::sin(700.0 * t);
  in.accel[1] = 0.1 * std::cos(700.0 * t);
  in.accel[2] = 9.81 + 0.01 * std::sin(300.0 * t);
  return in;
}

TEST(ImuIntake, AveragesTheGyroOverTheFusePeriod) {
  ImuIntake intake;
  intake.configure(ImuParams{});
  LocalizerCounters c;
  int ready = 0;
  for (int i = 0; i <= 10; ++i) {
    const GyroMeasurement g = intake.push(sample(1.0 + i * kImuPeriod, 0.1 + 0.01 * i), true, 1.0, c);
    if (!g.ready) continue;
    ++ready;
    EXPECT_NEAR(g.span, 0.01, 1e-9);
    EXPECT_NEAR(g.t, 1.0 + i * kImuPeriod, 1e-12);
    // The span [i - 2, i] of a rate ramping linearly between the samples: its mean is the middle
    // sample's rate (the samples' plain mean, 0.1 + 0.01 (i - 0.5), would be 2.5 ms later).
    EXPECT_NEAR(g.rate, 0.1 + 0.01 * (i - 1), 1e-12);
  }
  EXPECT_EQ(ready, 5);  // the first sample opens the span
  EXPECT_EQ(intake.recent().size(), 11u);
  EXPECT_TRUE(intake.live(1.06));
  EXPECT_FALSE(intake.live(1.2));
}

TEST(ImuIntake, RefusesAndCountsBadSamples) {
  ImuIntake intake;
  intake.configure(ImuParams{});
  LocalizerCounters c;
  intake.push(sample(1.0, 0.1), true, 1.0, c);
  ImuInput nan = sample(1.005, 0.1);
  nan.gyro[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(intake.push(nan, true, 1.0, c).ready);
  ImuInput sat = sample(1.005, 0.1);
  sat.saturated = true;
  EXPECT_FALSE(intake.push(sat, true, 1.0, c).ready);
  EXPECT_EQ(c.imu_invalid, 2u);
  EXPECT_TRUE(intake.push(sample(1.010, 0.1), true, 1.0, c).ready);
  EXPECT_FALSE(intake.push(sample(1.010, 0.1), true, 1.0, c).ready);  // repeated stamp
  EXPECT_FALSE(intake.push(sample(1.002, 0.1), true, 1.0, c).ready);  // older
  EXPECT_EQ(c.imu_out_of_order, 2u);
  EXPECT_FALSE(intake.push(sample(9.0, 0.1), true, 1.0, c).ready);    // 8 s ahead of the other inputs
  EXPECT_EQ(c.imu_time_jumps, 1u);
  // A 0.2 s silence: a dropout; the span restarts (the next sample only opens it).
  EXPECT_FALSE(intake.push(sample(1.21, 0.1), true, 1.2, c).ready);
  EXPECT_EQ(c.imu_gaps, 1u);
  EXPECT_EQ(intake.recent().size(), 1u);
  EXPECT_TRUE(intake.push(sample(1.22, 0.1), true, 1.2, c).ready);
}

TEST(ImuIntake, StuckGyroZIsCountedAndNotFused) {
  ImuParams p;
  ImuIntake intake;
  intake.configure(p);
  LocalizerCounters c;
  int ready_after_stuck = 0;
  for (int i = 0; i < 200; ++i) {
    ImuInput in = sample(1.0 + i * kImuPeriod, i < 20 ? 0.01 * i : 0.123);  // frozen from sample 20
    const GyroMeasurement g = intake.push(in, false, 0.0, c);
    if (g.ready && i >= 20 + static_cast<int>(p.stuck_samples)) ++ready_after_stuck;
  }
  EXPECT_EQ(c.imu_stuck_axes, 1u);
  EXPECT_EQ(ready_after_stuck, 0);
  EXPECT_FALSE(intake.live(1.0 + 199 * kImuPeriod));
  // It moves again: fused again.
  EXPECT_FALSE(intake.push(sample(2.0, 0.2), false, 0.0, c).ready);  // opens the span
  EXPECT_FALSE(intake.push(sample(2.005, 0.21), false, 0.0, c).ready);
  EXPECT_TRUE(intake.push(sample(2.01, 0.22), false, 0.0, c).ready);
}

// ---- The filter on a synthetic drive ----

struct Drive {
  double duration = 40.0;     // [s]
  double speed = 8.0;         // [m/s]
  bool imu = true;
  double gyro_bias = 0.01;    // [rad/s] turn-on bias (0.57 deg/s)
  double gyro_scale = 0.0;    // [-] scale error (z = (1 + s) w + b)
  double gyro_sigma = 8.7e-5 / std::sqrt(kImuPeriod);  // per sample, from the noise density
  double can_bias = 0.002;    // [rad/s], walking 2e-4 rad/s/sqrt(s), noise 0.003 (host_sim's CAN)
  double can_walk = 2e-4;
  double can_sigma = 0.003;
  double blind_from = -1.0, blind_to = -1.0;      // [s] no registrations
  double dropout_from = -1.0, dropout_to = -1.0;  // [s] no IMU samples
  double stuck_from = -1.0;                       // [s] gyro z frozen from then on
  double step_at = -1.0, step = 0.0;              // [s], [rad/s] gyro bias step
  bool batched = false;  // a period's IMU samples after its CAN frames, before the scan (out of sequence)
  std::uint64_t seed = 7;
};

struct DriveOutcome {
  double yaw_error_at_blind_end = 0.0;  // [rad]
  double position_error_at_blind_end = 0.0;  // [m]
  double yaw_drift = 0.0;               // [rad] change of the yaw error over the blind spell
  double position_drift = 0.0;          // [m] change of the horizontal error vector over it
  double max_yaw_error = 0.0;           // [rad] over frames after the first 5 s
  double final_gyro_bias_error = 0.0;   // [rad/s]
  double final_gyro_scale_error = 0.0;  // [-]
  double max_gyro_bias_error_after_curve = 0.0;  // [rad/s] from the hard curve's end (27 s) on
  double gyro_bias_error_at_blind_start = 0.0;  // [rad/s]
  double can_bias_error_at_blind_start = 0.0;   // [rad/s]
  int frames = 0, poses = 0;            // frames, and frames with a finite filter pose
  // The deskew's yaw rate against the true mean rate over the sweep after the stamp (RMS, rad/s):
  // the gyro's (filter.imu.deskew_window, less the bias) and the latest CAN sample's.
  double deskew_rate_error_gyro = 0.0, deskew_rate_error_can = 0.0;
  int deskew_frames = 0;
  LocalizerCounters counters{};
  EkfCounters ekf{};
};

// [rad/s] gentle S-curves, and from 20 s to 27 s a hard curve (0.25 rad/s more, 1 s raised-cosine edges).
double yaw_rate_at(double t) {
  double hard = 0.0;
  if (t > 20.0 && t < 27.0) hard = 1.0;
  if (t > 20.0 && t < 21.0) hard = 0.5 - 0.5 * std::cos(M_PI * (t - 20.0));
  if (t > 26.0 && t < 27.0) hard = 0.5 + 0.5 * std::cos(M_PI * (t - 26.0));
  return 0.2 * std::sin(2.0 * M_PI * t / 12.0) + 0.25 * hard;
}

// A registration of the true pose with noise, its information made so that the filter's
// covariance is (sigma_p, sigma_p, sigma_z, sigma_yaw) at any distance from the origin.
RegistrationResult registration(const Vec3d& p, double yaw, std::mt19937_64& rng) {
  const double sp = 0.05, sz = 0.05, sr = 0.003;
  std::normal_distribution<double> n(0.0, 1.0);
  RegistrationResult r;
  r.status = RegistrationStatus::kOk;
  r.fitness = 0.9;
  r.inlier_rmse = 0.1;
  r.transform.topLeftCorner<3, 3>() = rot_z(yaw + sr * n(rng));
  r.transform.topRightCorner<3, 1>() = p + Vec3d(sp * n(rng), sp * n(rng), sz * n(rng));
  Mat6d D = Mat6d::Zero();
  const double d[6] = {sr * sr, sr * sr, sr * sr, sp * sp, sp * sp, sz * sz};
  for (int i = 0; i < 6; ++i) D(i, i) = d[i];
  Mat6d A = Mat6d::Identity();  // twist about the world origin: tau = tau' + [p]x omega
  A.block<3, 3>(3, 0) = skew(p);
  const Mat6d cov6 = A * D * A.transpose();
  const RegistrationCovarianceParams cp;
  r.information = (cp.scale * r.inlier_rmse * r.inlier_rmse) * cov6.inverse();
  return r;
}

DriveOutcome drive(const Drive& d, const PoseFilterParams& base) {
  PoseFilterParams params = base;
  params.gate_mode = GateMode::kOff;
  auto filter = std::make_unique<PoseFilter>();
  filter->configure(params, true);
  ImuIntake intake;
  intake.configure(params.imu);
  std::mt19937_64 rng(d.seed), imu_rng(d.seed + 1000);  // the IMU's noise apart: the other inputs' is the same with or without it
  std::normal_distribution<double> n(0.0, 1.0);
  DriveOutcome out;
  Vec3d p(50.0, -20.0, 0.0);
  double yaw = 0.4, t = 10.0, can_bias = d.can_bias, stuck = 0.0, start_yaw_error = 0.0;
  Vec3d start_pos_error = Vec3d::Zero();
  double last_can = 0.0;
  std::vector<ImuInput> pending;
  const int steps = static_cast<int>(d.duration / kImuPeriod);
  Mat4d start = Mat4d::Identity();
  start.topLeftCorner<3, 3>() = rot_z(yaw);
  start.topRightCorner<3, 1>() = p;
  filter->start(t, Pose3d(start), VehicleMotion{true, d.speed, yaw_rate_at(0.0)});
  for (int k = 1; k <= steps; ++k) {
    const double s = k * kImuPeriod;  // drive time
    const double w = yaw_rate_at(s - 0.5 * kImuPeriod);
    const double yaw_mid = yaw + 0.5 * w * kImuPeriod;
    p += d.speed * kImuPeriod * Vec3d(std::cos(yaw_mid), std::sin(yaw_mid), 0.0);
    yaw = det::wrap_pi(yaw + w * kImuPeriod);
    t += kImuPeriod;
    const double w_now = yaw_rate_at(s);
    const bool dropped = s >= d.dropout_from && s < d.dropout_to;
    if (d.imu && !dropped) {
      // The sample's rate at its time stamp (hal/HID_IMU_REPORT.md: the instant the rate applies to).
      double gz = (1.0 + d.gyro_scale) * w_now + d.gyro_bias + (d.step_at >= 0.0 && s >= d.step_at ? d.step : 0.0) + d.gyro_sigma * n(imu_rng);
      if (d.stuck_from >= 0.0 && s >= d.stuck_from) {
        if (stuck == 0.0) stuck = gz;
        gz = stuck;
      }
      ImuInput in;
      in.t = t;
      in.gyro[0] = 1e-3 * n(imu_rng);
      in.gyro[1] = 1e-3 * n(imu_rng);
      in.gyro[2] = gz;
      for (int a = 0; a < 3; ++a) in.accel[a] = (a == 2 ? 9.81 : 0.0) + 0.01 * n(imu_rng);
      if (d.batched) {
        pending.push_back(in);
      } else {
        const GyroMeasurement g = intake.push(in, true, t, out.counters);
        if (g.ready) filter->on_gyro(g.t, g.rate, g.span, out.counters);
      }
    }
    if (k % 2 == 0) {
      can_bias += d.can_walk * std::sqrt(2 * kImuPeriod) * n(rng);
      last_can = w_now + can_bias + d.can_sigma * n(rng);
      filter->on_vehicle(t, d.speed + 0.05 * n(rng), last_can);
    }
    if (k % 20 != 0) continue;
    for (const ImuInput& in : pending) {
      const GyroMeasurement g = intake.push(in, true, t, out.counters);
      if (g.ready) filter->on_gyro(g.t, g.rate, g.span, out.counters);
    }
    pending.clear();
    filter->predict_to(t);
    const bool blind = s >= d.blind_from && s < d.blind_to;
    if (!blind) {
      FrameRegistration reg;
      reg.frame = static_cast<std::uint32_t>(out.frames);
      reg.t = t;
      reg.result = registration(p, yaw, rng);
      reg.attempted_ok = true;
      reg.vehicle = VehicleMotion{true, d.speed, w_now};
      filter->fuse(reg, out.counters);
    }
    ++out.frames;
    double gyro_rate = 0.0;
    if (s > 5.0 && intake.rate_ahead(t, params.imu.deskew_window, params.imu.deskew_trend, 0.05, gyro_rate)) {
      double sweep_rate = 0.0;  // the truth's mean over the 0.1 s sweep
      for (int j = 0; j < 10; ++j) sweep_rate += 0.1 * yaw_rate_at(s + 0.005 + 0.01 * j);
      const double eg = filter->corrected_gyro_rate(gyro_rate) - sweep_rate, ec = last_can - sweep_rate;
      out.deskew_rate_error_gyro += eg * eg;
      out.deskew_rate_error_can += ec * ec;
      ++out.deskew_frames;
    }
    const EkfState e = filter->ekf().state();
    const double yaw_error = std::fabs(det::wrap_pi(e.yaw - yaw));
    if (filter->initialized() && std::isfinite(e.pos_x) && std::isfinite(e.yaw)) ++out.poses;
    if (s > 5.0 && yaw_error > out.max_yaw_error) out.max_yaw_error = yaw_error;
    const double yaw_signed = det::wrap_pi(e.yaw - yaw);
    const Vec3d pos_error(e.pos_x - p.x(), e.pos_y - p.y(), 0.0);
    if (std::fabs(s - d.blind_from) < 0.5 * kImuPeriod) {
      start_yaw_error = yaw_signed;
      start_pos_error = pos_error;
      out.gyro_bias_error_at_blind_start = e.gyro_bias - d.gyro_bias - (d.step_at >= 0.0 && s >= d.step_at ? d.step : 0.0);
      out.can_bias_error_at_blind_start = e.yaw_rate_bias - can_bias;
    }
    if (std::fabs(s - d.blind_to) < 0.5 * kImuPeriod) {
      out.yaw_error_at_blind_end = yaw_error;
      out.position_error_at_blind_end = pos_error.norm();
      out.yaw_drift = std::fabs(yaw_signed - start_yaw_error);
      out.position_drift = (pos_error - start_pos_error).norm();
    }
    const double bias_now = d.gyro_bias + (d.step_at >= 0.0 && s >= d.step_at ? d.step : 0.0);
    out.final_gyro_bias_error = e.gyro_bias - bias_now;
    out.final_gyro_scale_error = e.gyro_scale - d.gyro_scale;
    if (s > 27.0 && std::fabs(out.final_gyro_bias_error) > out.max_gyro_bias_error_after_curve) {
      out.max_gyro_bias_error_after_curve = std::fabs(out.final_gyro_bias_error);
    }
  }
  out.ekf = filter->ekf().counters();
  if (out.deskew_frames > 0) {
    out.deskew_rate_error_gyro = std::sqrt(out.deskew_rate_error_gyro / out.deskew_frames);
    out.deskew_rate_error_can = std::sqrt(out.deskew_rate_error_can / out.deskew_frames);
  }
  return out;
}

TEST(ImuFilter, GyroBiasConvergesOnACurve) {
  const DriveOutcome o = drive(Drive{}, PoseFilterParams{});
  std::printf("gyro bias error at the end %.2e rad/s, max yaw error %.2e rad, gyro fused %llu rejected %llu\n",
              o.final_gyro_bias_error, o.max_yaw_error, static_cast<unsigned long long>(o.ekf.gyro_fused),
              static_cast<unsigned long long>(o.ekf.gyro_rejected));
  EXPECT_LT(std::fabs(o.final_gyro_bias_error), 5e-4);  // from 0.01 rad/s unknown at the start
  EXPECT_EQ(o.poses, o.frames);
  EXPECT_GT(o.ekf.gyro_fused, 3900u);                   // 100 Hz for 40 s
  EXPECT_LE(o.ekf.gyro_rejected, 4u);                   // 99.9 % gate
  EXPECT_EQ(o.counters.imu_bias_resets, 0u);
}

// The deskew's yaw rate: the gyro's mean over the last 20 ms before the stamp carried along its
// trend to the sweep's middle, less the filter's bias, against the latest CAN sample, both compared
// with the true mean rate over the sweep (which starts at the stamp).
TEST(ImuFilter, DeskewYawRateFromTheGyro) {
  const DriveOutcome o = drive(Drive{}, PoseFilterParams{});
  std::printf("deskew yaw rate, RMS error over the sweep: gyro %.2e rad/s, CAN %.2e rad/s (%d frames)\n",
              o.deskew_rate_error_gyro, o.deskew_rate_error_can, o.deskew_frames);
  EXPECT_GT(o.deskew_frames, 300);
  EXPECT_LT(o.deskew_rate_error_gyro, o.deskew_rate_error_can);
}

// Without IMU samples the gyro bias's and scale's variances only grow and never couple into the
// other states: their start sigmas change no other state's bit (why the 12 recordings stay
// byte-identical).
TEST(ImuFilter, WithoutImuSamplesTheGyroStatesTouchNothing) {
  Drive d;
  d.imu = false;
  d.duration = 15.0;
  PoseFilterParams a, b;
  b.restart_sigmas[idx::kGyroBias] = 3.0;
  b.restart_sigmas[idx::kGyroScale] = 0.5;
  auto run = [&](const PoseFilterParams& params, EkfVector& x, EkfCovariance& P) {
    PoseFilterParams p = params;
    p.gate_mode = GateMode::kOff;
    auto f = std::make_unique<PoseFilter>();
    f->configure(p, true);
    LocalizerCounters c;
    std::mt19937_64 rng(3);
    std::normal_distribution<double> n(0.0, 1.0);
    f->start(0.0, Pose3d::Identity(), VehicleMotion{true, 8.0, 0.1});
    for (int k = 1; k <= 1500; ++k) {
      const double t = 0.01 * k;
      f->on_vehicle(t, 8.0 + 0.05 * n(rng), 0.1 + 0.003 * n(rng));
      if (k % 10 != 0) continue;
      f->predict_to(t);
      FrameRegistration reg;
      reg.t = t;
      reg.result = registration(Vec3d(8.0 * t, 0.0, 0.0), 0.1 * t, rng);
      reg.attempted_ok = true;
      f->fuse(reg, c);
    }
    x = f->ekf().state_vector();
    P = f->ekf().covariance();
  };
  EkfVector xa, xb;
  EkfCovariance Pa, Pb;
  run(a, xa, Pa);
  run(b, xb, Pb);
  for (int i = 0; i < idx::kGyroBias; ++i) {
    EXPECT_EQ(xa(i), xb(i)) << "state " << i;
    for (int j = 0; j < idx::kGyroBias; ++j) EXPECT_EQ(Pa(i, j), Pb(i, j)) << i << "," << j;
    for (int g : {idx::kGyroBias, idx::kGyroScale}) {
      EXPECT_EQ(Pa(i, g), 0.0);
      EXPECT_EQ(Pb(i, g), 0.0);
    }
  }
  EXPECT_EQ(Pb(idx::kGyroBias, idx::kGyroScale), 0.0);
  EXPECT_GT(Pb(idx::kGyroBias, idx::kGyroBias), Pa(idx::kGyroBias, idx::kGyroBias));
  EXPECT_GT(Pb(idx::kGyroScale, idx::kGyroScale), Pa(idx::kGyroScale, idx::kGyroScale));
}

TEST(ImuFilter, DropoutFallsBackToTheCanYawRate) {
  for (const bool can_beside : {true, false}) {
    Drive d;
    d.dropout_from = 15.0;
    d.dropout_to = 18.0;
    d.blind_from = 15.0;
    d.blind_to = 18.0;
    PoseFilterParams p;
    p.imu.can_yaw_rate_with_gyro = can_beside;
    const DriveOutcome o = drive(d, p);
    std::printf("CAN beside %d: dropout + blind 3 s: yaw error %.2e rad, position error %.3f m\n", can_beside,
                o.yaw_error_at_blind_end, o.position_error_at_blind_end);
    EXPECT_EQ(o.counters.imu_gaps, 1u);
    EXPECT_EQ(o.poses, o.frames);
    EXPECT_LT(o.yaw_error_at_blind_end, 0.01);  // the CAN yaw rate carried the yaw
    EXPECT_LT(o.position_error_at_blind_end, 0.3);
  }
}

TEST(ImuFilter, StuckGyroIsDetectedAndTheYawHolds) {
  Drive d;
  d.stuck_from = 18.0;  // frozen just before the hard curve
  d.blind_from = 22.0;
  d.blind_to = 25.0;
  const DriveOutcome o = drive(d, PoseFilterParams{});
  std::printf("stuck gyro z: yaw error at the blind's end %.2e rad, max %.2e rad\n", o.yaw_error_at_blind_end,
              o.max_yaw_error);
  EXPECT_EQ(o.counters.imu_stuck_axes, 1u);
  EXPECT_EQ(o.poses, o.frames);
  EXPECT_LT(o.yaw_error_at_blind_end, 0.01);
}

TEST(ImuFilter, BiasStepIsDetectedAndReestimated) {
  Drive d;
  d.step_at = 15.0;
  d.step = 0.02;  // 1.15 deg/s
  d.blind_from = 16.0;
  d.blind_to = 19.0;
  const DriveOutcome o = drive(d, PoseFilterParams{});
  std::printf("bias step 0.02 rad/s: resets %u (inconsistent %u, rejected %u), yaw error at the blind's end "
              "%.2e rad, final bias error %.2e rad/s\n",
              o.counters.imu_bias_resets, o.counters.imu_inconsistent, o.counters.imu_gyro_rejected,
              o.yaw_error_at_blind_end, o.final_gyro_bias_error);
  EXPECT_GE(o.counters.imu_bias_resets, 1u);
  EXPECT_EQ(o.poses, o.frames);
  EXPECT_LT(std::fabs(o.final_gyro_bias_error), 1e-3);
  EXPECT_LT(o.yaw_error_at_blind_end, 0.01);
}

// A period's IMU samples delivered after its CAN frames: every gyro mean is
// older than the filter time and goes in through the EKF's rollback, with the same estimates as
// interleaved delivery up to rounding; the CAN comparison still finds the bias step.
TEST(ImuFilter, PeriodBatchedSamplesGiveTheSameFilter) {
  Drive d;
  d.step_at = 15.0;
  d.step = 0.02;
  d.blind_from = 21.0;
  d.blind_to = 24.0;
  const DriveOutcome interleaved = drive(d, PoseFilterParams{});
  d.batched = true;
  const DriveOutcome batched = drive(d, PoseFilterParams{});
  std::printf("batched: late gyro events %llu, bias resets %u, yaw drift %.2e rad (interleaved %.2e)\n",
              static_cast<unsigned long long>(batched.ekf.late_events), batched.counters.imu_bias_resets,
              batched.yaw_drift, interleaved.yaw_drift);
  EXPECT_GT(batched.ekf.late_events, 3000u);
  EXPECT_EQ(batched.ekf.too_late, 0u);
  EXPECT_GE(batched.counters.imu_bias_resets, 1u);
  EXPECT_EQ(batched.poses, batched.frames);
  EXPECT_LT(std::fabs(batched.final_gyro_bias_error), 1e-3);
  EXPECT_NEAR(batched.yaw_drift, interleaved.yaw_drift, 1e-4);
}

// A gyro with a 0.8 % scale error (1.6 sigma of the class) on the S-curves and the hard curve: the
// scale state takes the turns' share, so the bias is right on the straight after the curve. With the
// scale pinned at zero (start sigma and walk 0) the registrations' yaw corrections during the curve
// land in the bias instead.
TEST(ImuFilter, GyroScaleErrorConvergesOnTheTurns) {
  Drive d;
  d.gyro_scale = 0.008;
  d.duration = 32.0;
  PoseFilterParams pinned;
  pinned.restart_sigmas[idx::kGyroScale] = 0.0;
  pinned.ekf.noise.gyro_scale_walk = 0.0;
  const DriveOutcome with = drive(d, PoseFilterParams{});
  const DriveOutcome without = drive(d, pinned);
  std::printf("scale 0.8 %%: scale error at the end %.2e; gyro bias error after the curve, max: %.2e rad/s "
              "(scale pinned: %.2e); max yaw error %.2e rad (pinned: %.2e)\n",
              with.final_gyro_scale_error, with.max_gyro_bias_error_after_curve,
              without.max_gyro_bias_error_after_curve, with.max_yaw_error, without.max_yaw_error);
  EXPECT_LT(std::fabs(with.final_gyro_scale_error), 1.5e-3);  // from 0.8 % unknown at the start
  EXPECT_LT(std::fabs(with.final_gyro_bias_error), 5e-4);
  EXPECT_LT(with.max_gyro_bias_error_after_curve, 0.5 * without.max_gyro_bias_error_after_curve);
  EXPECT_LT(with.max_yaw_error, without.max_yaw_error);
  EXPECT_EQ(with.poses, with.frames);
  EXPECT_EQ(with.counters.imu_bias_resets, 0u);
}

// The benefit, measured: registrations absent for 3 s on the hard curve, over 20 seeds, with
// the gyro (CAN yaw rate beside it, or left out) and with the CAN yaw rate alone. The error at the
// spell's end holds the error at its start (the registrations' noise); the drift is the change.
TEST(ImuFilter, BlindThreeSecondsDriftWithAndWithoutTheGyro) {
  constexpr int kSeeds = 20;
  double yaw[3] = {0, 0, 0}, pos[3] = {0, 0, 0}, yaw_end[3] = {0, 0, 0}, pos_end[3] = {0, 0, 0};
  for (std::uint64_t seed = 1; seed <= kSeeds; ++seed) {
    for (int mode = 0; mode < 3; ++mode) {
      Drive d;
      d.seed = seed;
      d.imu = mode != 2;
      d.blind_from = 21.0;
      d.blind_to = 24.0;
      d.duration = 24.5;
      PoseFilterParams p;
      p.imu.can_yaw_rate_with_gyro = mode == 0;
      const DriveOutcome o = drive(d, p);
      yaw[mode] += o.yaw_drift * o.yaw_drift / kSeeds;
      pos[mode] += o.position_drift * o.position_drift / kSeeds;
      yaw_end[mode] += o.yaw_error_at_blind_end * o.yaw_error_at_blind_end / kSeeds;
      pos_end[mode] += o.position_error_at_blind_end * o.position_error_at_blind_end / kSeeds;
    }
  }
  const char* names[3] = {"gyro + CAN yaw rate", "gyro, CAN speed only", "CAN alone"};
  for (int m = 0; m < 3; ++m) {
    std::printf("blind 3 s, %-22s RMS drift: yaw %.2e rad, position %.4f m; RMS error at the end: yaw %.2e rad, "
                "position %.4f m\n",
                names[m], std::sqrt(yaw[m]), std::sqrt(pos[m]), std::sqrt(yaw_end[m]), std::sqrt(pos_end[m]));
  }
  EXPECT_LT(yaw[0], 0.5 * yaw[2]);
  EXPECT_LT(pos[0], pos[2]);
}

}  // namespace
}  // namespace v2xloc
