#include "v2xloc/algo/localization/pose_filter.hpp"

#include <cmath>
#include <memory>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/ground_attitude.hpp"

namespace v2xloc {

void PoseFilter::configure(const PoseFilterParams& params, bool use_vehicle_signals) {
  params_ = params;
  use_vehicle_signals_ = use_vehicle_signals;
  // Fresh filters built in place: `ekf_ = Ekf(...)` would first build each one's ~50 KB history
  // on the stack (the bare-metal target's stack is 64 KiB, docs/target.md).
  for (Ekf* ekf : {&ekf_, &shadow_}) {
    std::destroy_at(ekf);
    std::construct_at(ekf, params.ekf);
  }
  fixed_lag_gate_ = FixedLagValidityGate(params.gate);
  causal_gate_ = CausalValidityGate(params.gate);
  stereo_gate_ = CausalValidityGate(params.gate);
  for (auto& p : pending_) p = {};
  gate_pushes_ = 0;
  failed_frames_ = 0;
  nis_rejections_ = 0;
  nis_rejections_shadow_ = 0;
  gnss_divergent_fixes_ = 0;
  have_gyro_ = false;
  last_gyro_t_ = 0.0;
  can_next_ = 0;
  gyro_rejections_ = 0;
  can_gyro_running_ = false;
}

double PoseFilter::sigma_xy() const {
  const EkfCovariance& P = ekf_.covariance();
  return std::sqrt(0.5 * (P(ekf_index::kPosX, ekf_index::kPosX) + P(ekf_index::kPosY, ekf_index::kPosY)));
}

bool PoseFilter::can_track() const {
  const double sigma = ekf_.initialized() ? sigma_xy() : 1e9;
  return ekf_.initialized() && sigma <= params_.tracking_max_sigma_xy &&
         failed_frames_ <= params_.max_failed_frames;
}

void PoseFilter::on_vehicle(double t, double wheel_speed, double yaw_rate) {
  if (!use_vehicle_signals_ || !ekf_.initialized()) return;
  can_[can_next_ % kCanRing] = {t, yaw_rate};  // the gyro's comparison, whichever arrives first
  ++can_next_;
  if (gyro_live(t) && !params_.imu.can_yaw_rate_with_gyro) {
    ekf_.on_wheel_speed(t, wheel_speed);
    if (params_.shadow_ungated_filter) shadow_.on_wheel_speed(t, wheel_speed);
    return;
  }
  ekf_.on_vehicle_signals(t, wheel_speed, yaw_rate);
  if (params_.shadow_ungated_filter) shadow_.on_vehicle_signals(t, wheel_speed, yaw_rate);
}

void PoseFilter::on_gyro(double t, double rate, double span, LocalizerCounters& counters) {
  if (!ekf_.initialized()) return;
  if (params_.shadow_ungated_filter && shadow_.initialized()) shadow_.on_gyro(t, rate, span);
  const EkfFuseStatus s = ekf_.on_gyro(t, rate, span);
  if (s == EkfFuseStatus::kFused) {
    have_gyro_ = true;
    last_gyro_t_ = t;
    gyro_rejections_ = 0;
    watch_gyro_against_can(t, rate, span, counters);
    return;
  }
  if (s != EkfFuseStatus::kRejectedGate) return;
  ++counters.imu_gyro_rejected;
  if (++gyro_rejections_ < params_.imu.reset_after_rejections) return;
  reset_gyro_bias(t, counters);
}

// Both sensors see the same body yaw rate: the gyro less its bias, over its scale, minus the CAN
// rate less its bias, is the CAN signal's noise. The gyro's mean over its span is compared with the
// latest CAN sample inside that span (kept in a ring, so the comparison does not depend on which
// of the two reaches the filter first). A running mean (time constant consistency_window) beyond
// consistency_limit after a full window means the gyro's bias stepped faster than its random walk lets the filter follow (the
// gyro, far less noisy, would drag the yaw rate along otherwise).
void PoseFilter::watch_gyro_against_can(double t, double rate, double span, LocalizerCounters& counters) {
  const std::size_t n = can_next_ < kCanRing ? can_next_ : kCanRing;
  const CanSample* match = nullptr;
  for (std::size_t k = 1; k <= n && match == nullptr; ++k) {
    const CanSample& c = can_[(can_next_ - k) % kCanRing];
    if (c.t <= t && c.t > t - span) match = &c;
  }
  if (match == nullptr) return;
  const EkfState s = ekf_.state();
  const double d = corrected_gyro_rate(rate) - (match->yaw_rate - s.yaw_rate_bias);
  if (!can_gyro_running_ || !(t > can_gyro_t_) || t - can_gyro_t_ > params_.imu.max_gap) {
    can_gyro_running_ = true;
    can_gyro_mean_ = d;
    can_gyro_t_ = can_gyro_since_ = t;
    return;
  }
  double a = (t - can_gyro_t_) / params_.imu.consistency_window;
  if (a > 1.0) a = 1.0;
  can_gyro_mean_ += a * (d - can_gyro_mean_);
  can_gyro_t_ = t;
  if (t - can_gyro_since_ < params_.imu.consistency_window) return;
  if (std::fabs(can_gyro_mean_) <= params_.imu.consistency_limit) return;
  ++counters.imu_inconsistent;
  reset_gyro_bias(t, counters);
}

void PoseFilter::reset_gyro_bias(double t, LocalizerCounters& counters) {
  ekf_.reset_gyro_bias(t, params_.imu.bias_reset_sigma);
  if (params_.shadow_ungated_filter && shadow_.initialized()) shadow_.reset_gyro_bias(t, params_.imu.bias_reset_sigma);
  ++counters.imu_bias_resets;
  gyro_rejections_ = 0;
  can_gyro_running_ = false;
}

GnssFusion PoseFilter::on_gnss(double t, const Vec3d& enu, double h_acc, double v_acc) {
  if (ekf_.initialized()) {
    const EkfState s = ekf_.state();
    const double dx = s.pos_x - enu.x(), dy = s.pos_y - enu.y();
    const double limit = params_.gnss_divergence_sigmas * h_acc > params_.gnss_divergence_distance
                             ? params_.gnss_divergence_sigmas * h_acc
                             : params_.gnss_divergence_distance;
    gnss_divergent_fixes_ = dx * dx + dy * dy > limit * limit ? gnss_divergent_fixes_ + 1 : 0;
    if (params_.gnss_divergence_fixes > 0 && gnss_divergent_fixes_ >= params_.gnss_divergence_fixes) {
      return GnssFusion::kDiverged;
    }
  }
  if (!ekf_.initialized()) return GnssFusion::kIgnored;
  ekf_.on_gnss(t, enu, h_acc, v_acc);
  if (params_.shadow_ungated_filter) shadow_.on_gnss(t, enu, h_acc, v_acc);
  return GnssFusion::kFused;
}

void PoseFilter::on_odometry(double t, double dt, const Mat4d& body_delta) {
  if (!params_.use_odometry || !ekf_.initialized()) return;
  const Pose3d prev_T_curr(body_delta);
  ekf_.on_odometry(t, dt, prev_T_curr);
  if (params_.shadow_ungated_filter) shadow_.on_odometry(t, dt, prev_T_curr);
}

void PoseFilter::on_road_grade(double t, double grade) {
  if (!ekf_.initialized()) return;
  ekf_.on_road_grade(t, grade, params_.road_grade_sigma);
  if (params_.shadow_ungated_filter) shadow_.on_road_grade(t, grade, params_.road_grade_sigma);
}

void PoseFilter::predict_to(double t) {
  if (!ekf_.initialized()) return;
  ekf_.predict_to(t);
  if (params_.shadow_ungated_filter) shadow_.predict_to(t);
}

void PoseFilter::start(double t, const Pose3d& pose, const VehicleMotion& vehicle) {
  restart(ekf_, t, pose.matrix(), vehicle);
  if (params_.shadow_ungated_filter) restart(shadow_, t, pose.matrix(), vehicle);
  failed_frames_ = 0;
}

Pose3d PoseFilter::start_pose(const RegistrationResult& confirmation, const RegistrationResult& candidate) const {
  const Mat4d& b = confirmation.transform;
  if (!candidate.ok() || !candidate.information.allFinite() || candidate.information.isZero(0.0)) return Pose3d(b);
  const Mat4d& a = candidate.transform;
  const PoseCovariance Ca = registration_covariance(candidate.information, candidate.inlier_rmse, Pose3d(a),
                                                    params_.registration_covariance);
  const PoseCovariance Cb = registration_covariance(confirmation.information, confirmation.inlier_rmse, Pose3d(b),
                                                    params_.registration_covariance);
  const Eigen::LDLT<PoseCovariance> sum(Ca + Cb);
  if (sum.info() != Eigen::Success || !sum.isPositive()) return Pose3d(b);
  Eigen::Matrix<double, 4, 1> d;
  d.head<3>() = a.topRightCorner<3, 1>() - b.topRightCorner<3, 1>();
  d(3) = det::wrap_pi(yaw_of(a.topLeftCorner<3, 3>()) - yaw_of(b.topLeftCorner<3, 3>()));
  const Eigen::Matrix<double, 4, 1> step = Cb * sum.solve(d);  // b + Cb (Ca + Cb)^-1 (a - b)
  if (!step.allFinite()) return Pose3d(b);
  Mat4d mean = b;
  mean.topRightCorner<3, 1>() += step.head<3>();
  mean.topLeftCorner<3, 3>() = rot_z(step(3)) * b.topLeftCorner<3, 3>();
  return Pose3d(mean);
}

bool PoseFilter::accepts_restart_at(const Pose3d& pose) const {
  if (!ekf_.initialized()) return true;
  const EkfState s = ekf_.state();
  const EkfCovariance& P = ekf_.covariance();
  const double k = params_.reacquire_gate_sigmas;
  const double dx = pose.translation().x() - s.pos_x;
  const double dy = pose.translation().y() - s.pos_y;
  const double reach = k * sigma_xy() + params_.reacquire_margin;
  const double yaw_reach = k * std::sqrt(P(ekf_index::kYaw, ekf_index::kYaw)) + params_.reacquire_yaw_margin;
  const double dyaw = det::wrap_pi(yaw_of(pose.rotation()) - s.yaw);
  return dx * dx + dy * dy <= reach * reach && std::fabs(dyaw) <= yaw_reach;
}

void PoseFilter::lose_track() {
  ekf_.reset();
  if (params_.shadow_ungated_filter) shadow_.reset();
  failed_frames_ = 0;
  nis_rejections_ = 0;
  nis_rejections_shadow_ = 0;
  gnss_divergent_fixes_ = 0;
  gyro_rejections_ = 0;
  can_gyro_running_ = false;
}

void PoseFilter::restart(Ekf& ekf, double t, const Mat4d& pose, const VehicleMotion& vehicle) const {
  EkfState s;
  s.pos_x = pose(0, 3);
  s.pos_y = pose(1, 3);
  s.pos_z = pose(2, 3);
  s.yaw = yaw_of(pose.topLeftCorner<3, 3>());
  s.speed = vehicle.speed;
  s.yaw_rate = vehicle.yaw_rate;
  // The body's pitch is the road's grade (a car's suspension pitches it by a few tenths of a degree).
  s.road_grade = road_grade_of(pose.topLeftCorner<3, 3>().col(0));
  EkfCovariance P = EkfCovariance::Zero();
  const double* sigmas = params_.restart_sigmas;
  for (int i = 0; i < kEkfStateSize; ++i) P(i, i) = sigmas[i] * sigmas[i];
  // The gyro's bias and scale outlive a restart (reset() keeps the last state).
  if (ekf.counters().gyro_fused > 0) {
    s.gyro_bias = ekf.state_vector()(ekf_index::kGyroBias);
    s.gyro_scale = ekf.state_vector()(ekf_index::kGyroScale);
    constexpr int kBias = ekf_index::kGyroBias;  // bias and scale: adjacent in the index table
    static_assert(ekf_index::kGyroScale == kBias + 1);
    P.block<2, 2>(kBias, kBias) = ekf.covariance().block<2, 2>(kBias, kBias);
  }
  ekf.initialize(t, s, P);
  ekf.predict_to(t);
}

RegistrationFusion PoseFilter::fuse(const FrameRegistration& in, LocalizerCounters& counters) {
  const RegistrationResult& result = in.result;
  const Now now{in.t, in.odom_T_body.matrix(), in.vehicle};
  Pending reg;
  reg.frame = in.frame;
  reg.t = in.t;
  reg.pose = result.transform;
  reg.odom = in.odom_T_body.matrix();
  reg.ok = in.attempted_ok && result.ok();
  reg.withheld = in.withheld;
  if (reg.ok) {
    reg.covariance = registration_covariance(result.information, result.inlier_rmse,
                                             Pose3d(result.transform), params_.registration_covariance);
    // The shadow filter takes every ok registration, before any gate.
    if (params_.shadow_ungated_filter) fuse_into(Which::kShadow, reg, now, counters);
  }
  RegistrationFusion out;
  out.fused = fuse_gate_decision(reg, GateSample{result.fitness, result.inlier_rmse, reg.ok}, now, out, counters);
  if (out.fused) {
    failed_frames_ = 0;
  } else if (!reg.ok && !in.no_data) {
    ++failed_frames_;
  }
  if (in.no_data) return out;  // no registration to reject
  if (!reg.ok || (params_.gate_mode != GateMode::kFixedLag && !out.fused)) {
    ++counters.registrations_gate_rejected;
  }
  return out;
}

// The gate in use decides; the registration it accepted (this frame's, or fixed-lag w/2 frames
// ago) goes to the main filter. True when the main filter took it.
bool PoseFilter::fuse_gate_decision(const Pending& reg, const GateSample& sample, const Now& now,
                                    RegistrationFusion& out, LocalizerCounters& counters) {
  switch (params_.gate_mode) {
    case GateMode::kOff:
      return reg.ok && !reg.withheld && fuse_into(Which::kMain, reg, now, counters);
    case GateMode::kCausal: {
      const GateDecision d = causal_gate_.push(sample);
      out.gate_decided = d.available;
      out.gate_decided_frame = static_cast<std::uint32_t>(d.frame);
      out.gate_decided_valid = d.valid && !reg.withheld;
      return out.gate_decided_valid && reg.ok && fuse_into(Which::kMain, reg, now, counters);
    }
    case GateMode::kFixedLag: {
      // The gate counts its own pushes (frames without a registration attempt are not pushed);
      // the ring is indexed by that count and remembers the localizer frame.
      Pending& slot = pending_[gate_pushes_ % kPendingCapacity];
      slot = reg;
      slot.gate_index = gate_pushes_++;
      const GateDecision d = fixed_lag_gate_.push(sample);
      if (!d.available) return false;
      const Pending& late = pending_[d.frame % kPendingCapacity];
      if (late.gate_index != d.frame) return false;
      out.gate_decided = true;
      out.gate_decided_frame = late.frame;
      out.gate_decided_valid = d.valid && !late.withheld;
      return out.gate_decided_valid && late.ok && fuse_into(Which::kMain, late, now, counters);
    }
  }
  return false;
}

// A registration the validity gate accepted but the filter's NIS gate keeps rejecting means the
// filter, not the registration, is wrong (it drifted on odometry while over-confident): after
// reset_after_rejections such frames in a row the filter restarts at the registration.
bool PoseFilter::fuse_into(Which which, const Pending& reg, const Now& now, LocalizerCounters& counters) {
  Ekf& ekf = which == Which::kMain ? ekf_ : shadow_;
  std::uint32_t& rejections = which == Which::kMain ? nis_rejections_ : nis_rejections_shadow_;
  if (!ekf.initialized()) return false;
  const EkfFuseStatus status = ekf.on_registration(reg.t, Pose3d(reg.pose), reg.covariance);
  if (status == EkfFuseStatus::kFused) {
    rejections = 0;
    if (which == Which::kMain) ++counters.registrations_fused;  // the published filter's count
    return true;
  }
  if (status != EkfFuseStatus::kRejectedGate) return false;
  if (++rejections < params_.reset_after_rejections) return false;
  rejections = 0;
  ++counters.filter_resets;
  // A fixed-lag registration is w/2 frames old: restart at the current frame with its pose
  // carried forward by the odometry (restarting at its own time stamp would leave the output
  // behind by the distance driven since, ~3 m at 6 m/s).
  restart(ekf, now.t, carried_by_odometry(reg.pose, reg.odom, now.odom_T_body), now.vehicle);
  return true;
}

bool PoseFilter::fuse_stereo(double t, const RegistrationResult& r, double depth_sigma) {
  const GateDecision d = stereo_gate_.push(GateSample{r.fitness, r.inlier_rmse, r.ok()});
  if (!d.valid || !r.ok()) return false;
  const double sigma = r.inlier_rmse > depth_sigma ? r.inlier_rmse : depth_sigma;
  RegistrationCovarianceParams cp = params_.registration_covariance;
  cp.scale *= params_.stereo_covariance_scale;
  const Pose3d world_T_body(r.transform);
  const PoseCovariance cov = registration_covariance(r.information, sigma, world_T_body, cp);
  if (params_.shadow_ungated_filter) shadow_.on_registration(t, world_T_body, cov);
  return ekf_.on_registration(t, world_T_body, cov) == EkfFuseStatus::kFused;
}

}  // namespace v2xloc
