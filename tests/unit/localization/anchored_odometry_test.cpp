// Anchored odometry (ekf.hpp): once the filter has converged, the odometry's pose since an anchor
// clone is fused every frame. It must carry the pose through a spell without registrations better
// than the per-frame rates do, refuse a frame whose odometry slipped (and start a new anchor), and
// wait for a converged filter before it arms.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/ekf.hpp"

namespace v2xloc {
namespace {

namespace idx = ekf_index;

constexpr double kSpeed = 8.0;      // [m/s]
constexpr double kYawRate = 0.02;   // [rad/s] a gentle curve
constexpr double kFrame = 0.1;      // [s]

struct Planar {
  double x = 0.0, y = 0.0, yaw = 0.0;
};

Planar truth_at(double t) {
  const double yaw = kYawRate * t;
  return {kSpeed / kYawRate * std::sin(yaw), kSpeed / kYawRate * (1.0 - std::cos(yaw)), yaw};
}

Mat4d matrix_of(const Planar& p) {
  Mat4d m = Mat4d::Identity();
  m.topLeftCorner<3, 3>() = rot_z(p.yaw);
  m(0, 3) = p.x;
  m(1, 3) = p.y;
  return m;
}

struct DriveResult {
  double error = 0.0;  // [m] horizontal, at the end
  double sigma = 0.0;  // [m] the filter's (x, y mean)
  EkfCounters counters;
};

// Registrations (1 cm) every frame until gap_start, none after; odometry every frame with a white
// 8 mm / 2e-4 rad error on each frame's pose (its deltas: differences of noisy poses);
// slip_frame >= 0: that frame's odometry is 0.5 m off along the track.
DriveResult drive(const EkfParams& params, unsigned seed, double gap_start, double end, int slip_frame = -1,
                  double initial_sigma = 0.05) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  auto f = std::make_unique<Ekf>(params);
  EkfState s;
  s.speed = kSpeed;
  s.yaw_rate = kYawRate;
  EkfCovariance P = EkfCovariance::Zero();
  const double sd[kEkfStateSize] = {initial_sigma, initial_sigma, 0.05, 0.005, 0.1, 0.01, 0.002, 0.01,
                                    0.01,          0.005,         0.01, 0.005, 0.05, 0.05};
  for (int i = 0; i < kEkfStateSize; ++i) P(i, i) = sd[i] * sd[i];
  f->initialize(0.0, s, P);
  Mat4d last_odometry = matrix_of(truth_at(0.0));
  int frame = 0;
  for (double t = kFrame; t <= end + 1e-9; t += kFrame, ++frame) {
    for (int k = 1; k <= 10; ++k) {
      const double tk = t - kFrame + 0.01 * k;
      f->on_vehicle_signals(tk, kSpeed + 0.05 * n(rng), kYawRate + 0.005 * n(rng));
    }
    f->predict_to(t);
    const Planar truth = truth_at(t);
    Planar seen = truth;
    seen.x += 0.008 * n(rng);
    seen.y += 0.008 * n(rng);
    seen.yaw += 2e-4 * n(rng);
    const Mat4d odometry = matrix_of(seen);
    Mat4d delta = last_odometry.inverse() * odometry;
    if (frame == slip_frame) delta(0, 3) += 0.5;
    last_odometry = odometry;
    f->on_odometry(t, kFrame, Pose3d(delta));
    if (t < gap_start) {
      Planar r = truth;
      r.x += 0.01 * n(rng);
      r.y += 0.01 * n(rng);
      Mat4d pose = matrix_of(r);
      PoseCovariance cov = PoseCovariance::Zero();
      cov.diagonal() << 1e-4, 1e-4, 1e-4, 1e-6;
      pose.topLeftCorner<3, 3>() = rot_z(truth.yaw + 1e-3 * n(rng));
      f->on_registration(t, Pose3d(pose), cov);
    }
  }
  const EkfState e = f->state();
  const Planar truth = truth_at(end);
  DriveResult out;
  out.error = std::hypot(e.pos_x - truth.x, e.pos_y - truth.y);
  const EkfCovariance& C = f->covariance();
  out.sigma = std::sqrt(0.5 * (C(idx::kPosX, idx::kPosX) + C(idx::kPosY, idx::kPosY)));
  out.counters = f->counters();
  return out;
}

TEST(AnchoredOdometry, CarriesThePoseThroughASpellWithoutRegistrations) {
  EkfParams anchored;
  EkfParams rates = anchored;
  rates.noise.anchor_span = 0.0;  // the yaw window and the per-frame rates alone
  constexpr int kRuns = 20;
  double err_anchored = 0.0, err_rates = 0.0, nees = 0.0;
  for (int run = 0; run < kRuns; ++run) {
    const DriveResult a = drive(anchored, 100 + run, 5.0, 15.0);
    const DriveResult b = drive(rates, 100 + run, 5.0, 15.0);
    EXPECT_GT(a.counters.odometry_anchor_fused, 90u);  // armed within the first seconds
    EXPECT_EQ(b.counters.odometry_anchor_fused, 0u);
    err_anchored += a.error * a.error / kRuns;
    err_rates += b.error * b.error / kRuns;
    nees += a.error * a.error / (2.0 * a.sigma * a.sigma) / kRuns;
  }
  std::printf("10 s without registrations: rms error %.4f m anchored, %.4f m rates alone; mean NEES/dof %.2f\n",
              std::sqrt(err_anchored), std::sqrt(err_rates), nees);
  EXPECT_LT(std::sqrt(err_anchored), 0.5 * std::sqrt(err_rates));
  // Never over-confident: the sigma covers the error (NEES per DoF <= 1 within the runs' spread).
  // Well below 1 here: this odometry has no map drift, the filter allows 6e-5 rad/sqrt(m) of yaw
  // drift, ~4 cm sideways over the 80 m spell.
  EXPECT_LT(nees, 2.0);
}

TEST(AnchoredOdometry, ASlippedChainIsRefusedThenANewAnchorTaken) {
  const EkfParams params;
  const DriveResult clean = drive(params, 7, 5.0, 12.0);
  const DriveResult slipped = drive(params, 7, 5.0, 12.0, /*slip_frame=*/80);
  EXPECT_EQ(clean.counters.odometry_anchor_rejected, 0u);
  // The slip stays in the chain since the anchor: refused frame after frame until the refusals
  // persist for anchor_max_refused frames, then a new anchor and the frames after it fused again.
  EXPECT_EQ(slipped.counters.odometry_anchor_rejected, params.gates.anchor_max_refused);
  EXPECT_EQ(slipped.counters.odometry_anchor_fused + params.gates.anchor_max_refused,
            clean.counters.odometry_anchor_fused);
  // The 0.5 m slip does not reach the pose (its rate part moves the speed state for one frame only).
  EXPECT_LT(slipped.error, clean.error + 0.05);
}

TEST(AnchoredOdometry, ArmsOnlyOnceTheFilterHasConverged) {
  const EkfParams params;
  // Metres of initial uncertainty and no registrations: the filter never converges, never arms.
  const DriveResult lost = drive(params, 3, /*gap_start=*/0.0, 10.0, -1, /*initial_sigma=*/3.0);
  EXPECT_EQ(lost.counters.odometry_anchor_fused, 0u);
  EXPECT_GT(lost.counters.odometry_windows_fused, 5u);  // the yaw window holds the heading meanwhile
}

}  // namespace
}  // namespace v2xloc
