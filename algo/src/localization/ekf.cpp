#include "v2xloc/algo/localization/ekf.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {

namespace idx = ekf_index;
using Mat4x4 = Eigen::Matrix<double, 4, 4>;

EkfVector EkfState::to_vector() const {
  EkfVector x;
  x << pos_x, pos_y, pos_z, yaw, speed, yaw_rate, yaw_rate_bias, wheel_scale, gyro_bias, gyro_scale, road_grade,
      anchor_yaw, anchor_x, anchor_y;
  return x;
}

EkfState EkfState::from_vector(const EkfVector& x) {
  EkfState s;
  s.pos_x = x(idx::kPosX);
  s.pos_y = x(idx::kPosY);
  s.pos_z = x(idx::kPosZ);
  s.yaw = x(idx::kYaw);
  s.speed = x(idx::kSpeed);
  s.yaw_rate = x(idx::kYawRate);
  s.yaw_rate_bias = x(idx::kYawRateBias);
  s.wheel_scale = x(idx::kWheelScale);
  s.gyro_bias = x(idx::kGyroBias);
  s.gyro_scale = x(idx::kGyroScale);
  s.road_grade = x(idx::kRoadGrade);
  s.anchor_yaw = x(idx::kAnchorYaw);
  s.anchor_x = x(idx::kAnchorX);
  s.anchor_y = x(idx::kAnchorY);
  return s;
}

Pose3d EkfState::pose() const {
  Mat4d T = Mat4d::Identity();
  T.topLeftCorner<3, 3>() = rot_z(yaw);
  T.topRightCorner<3, 1>() = position();
  return Pose3d(T);
}

PoseCovariance registration_covariance(const Mat6d& information, double inlier_rmse,
                                      const Pose3d& world_T_body, const RegistrationCovarianceParams& params) {
  const Mat4d& pose = world_T_body.matrix();
  Mat4x4 cov = Mat4x4::Zero();
  const double huge = 1e6;  // "no information": the NIS gate or the filter will ignore it
  bool ok = information.allFinite() && std::isfinite(inlier_rmse);
  Mat6d cov6 = Mat6d::Zero();
  if (ok) {
    const Eigen::LDLT<Mat6d> ldlt(information);
    ok = ldlt.info() == Eigen::Success && ldlt.isPositive() &&
         (ldlt.vectorD().array() > 1e-12 * information.diagonal().maxCoeff()).all();
    if (ok) {
      const double sigma = inlier_rmse > params.min_rmse ? inlier_rmse : params.min_rmse;
      // Column by column: vector right-hand sides keep Eigen off its blocked (heap-using) path.
      for (int c = 0; c < 6; ++c) {
        cov6.col(c) = (params.scale * sigma * sigma) * ldlt.solve(Vec6d::Unit(c));
      }
      cov6 = 0.5 * (cov6 + cov6.transpose());
    }
  }
  if (!ok) {
    cov.diagonal().setConstant(huge);
    return cov;
  }
  // Jacobian of (vehicle position, yaw) w.r.t. the twist (rx, ry, rz, tx, ty, tz).
  Eigen::Matrix<double, 4, 6> G = Eigen::Matrix<double, 4, 6>::Zero();
  G.block<3, 3>(0, 0) = -skew(Vec3d(pose.topRightCorner<3, 1>()));
  G.block<3, 3>(0, 3) = Mat3d::Identity();
  G(3, 2) = 1.0;
  const Eigen::Matrix<double, 4, 6> Gc = G.lazyProduct(cov6);
  cov = Gc.lazyProduct(G.transpose());
  cov = 0.5 * (cov + cov.transpose());
  const double floors[4] = {params.min_sigma_xy, params.min_sigma_xy, params.min_sigma_z,
                            params.min_sigma_yaw};
  for (int i = 0; i < 4; ++i) {
    const double f2 = floors[i] * floors[i];
    if (cov(i, i) < f2) cov(i, i) = f2;
  }
  return cov;
}

Ekf::Ekf(const EkfParams& params) : params_(params) {}

void Ekf::initialize(double t, const EkfState& state, const EkfCovariance& covariance) {
  x_ = state.to_vector();
  x_(idx::kYaw) = det::wrap_pi(x_(idx::kYaw));
  P_ = 0.5 * (covariance + covariance.transpose());
  time_ = t;
  gyro_chain_ = {};
  odometry_chain_ = {};
  initialized_ = true;
  log_size_ = 0;
  snap_first_ = 0;
  snap_count_ = 0;
  take_snapshot(0);
}

void Ekf::reset() {
  initialized_ = false;
  log_size_ = 0;
  snap_first_ = 0;
  snap_count_ = 0;
}

EkfFuseStatus Ekf::on_vehicle_signals(double t, double wheel_speed, double yaw_rate) {
  Event e;
  e.t = t;
  e.type = EkfEventType::kVehicleSignals;
  e.z[0] = wheel_speed;
  e.z[1] = yaw_rate;
  e.R[0][0] = params_.noise.wheel_speed * params_.noise.wheel_speed;
  e.R[1][1] = params_.noise.gyro * params_.noise.gyro;
  return submit(e);
}

EkfFuseStatus Ekf::on_road_grade(double t, double grade, double sigma) {
  Event e;
  e.t = t;
  e.type = EkfEventType::kRoadGrade;
  e.z[0] = grade;
  e.R[0][0] = sigma * sigma;
  return submit(e);
}

EkfFuseStatus Ekf::on_wheel_speed(double t, double wheel_speed) {
  Event e;
  e.t = t;
  e.type = EkfEventType::kWheelSpeed;
  e.z[0] = wheel_speed;
  e.R[0][0] = params_.noise.wheel_speed * params_.noise.wheel_speed;
  return submit(e);
}

EkfFuseStatus Ekf::on_gyro(double t, double rate, double span) {
  if (!(span > 0.0)) {
    ++counters_.invalid_inputs;
    return EkfFuseStatus::kInvalidInput;
  }
  Event e;
  e.t = t;
  e.type = EkfEventType::kGyro;
  e.z[0] = rate;
  e.z[1] = span;
  // White rate noise averaged over the span (the scale error is a state).
  const double n = params_.noise.gyro_noise_density;
  e.R[0][0] = n * n / span;
  return submit(e);
}

EkfFuseStatus Ekf::reset_gyro_bias(double t, double sigma) {
  Event e;
  e.t = t;
  e.type = EkfEventType::kGyroBiasReset;
  e.R[0][0] = sigma * sigma;
  return submit(e);
}

EkfFuseStatus Ekf::on_gnss(double t, const Vec3d& enu, double sigma_horizontal,
                           double sigma_vertical) {
  Event e;
  e.t = t;
  e.type = EkfEventType::kGnss;
  const double k = params_.gates.gnss_sigma_inflation;
  const double sh = k * sigma_horizontal, sv = k * sigma_vertical;
  if (!(sh > 0.0) || !(sv > 0.0)) {
    ++counters_.invalid_inputs;
    return EkfFuseStatus::kInvalidInput;
  }
  for (int i = 0; i < 3; ++i) e.z[i] = enu(i);
  e.R[0][0] = e.R[1][1] = sh * sh;
  e.R[2][2] = sv * sv;
  return submit(e);
}

EkfFuseStatus Ekf::on_registration(double t, const Pose3d& world_T_body, const PoseCovariance& covariance) {
  const Mat4d& pose = world_T_body.matrix();
  Event e;
  e.t = t;
  e.type = EkfEventType::kRegistration;
  e.z[0] = pose(0, 3);
  e.z[1] = pose(1, 3);
  e.z[2] = pose(2, 3);
  e.z[3] = yaw_of(pose.topLeftCorner<3, 3>());
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) e.R[r][c] = 0.5 * (covariance(r, c) + covariance(c, r));
  return submit(e);
}

EkfFuseStatus Ekf::on_odometry(double t, double dt, const Pose3d& prev_T_curr) {
  const Mat4d& relative_pose = prev_T_curr.matrix();
  if (!(dt > 0.0)) {
    ++counters_.invalid_inputs;
    return EkfFuseStatus::kInvalidInput;
  }
  Event e;
  e.t = t;
  e.type = EkfEventType::kOdometry;
  e.z[0] = relative_pose(0, 3) / dt;
  e.z[1] = yaw_of(relative_pose.topLeftCorner<3, 3>());
  e.z[2] = dt;
  e.z[3] = relative_pose(1, 3);
  e.R[0][0] = params_.noise.odometry_speed * params_.noise.odometry_speed;
  e.R[1][1] = params_.noise.odometry_yaw_rate * params_.noise.odometry_yaw_rate;
  e.R[2][2] = params_.noise.odometry_yaw * params_.noise.odometry_yaw;  // the window's, before its turn
  return submit(e);
}

EkfFuseStatus Ekf::predict_to(double t) {
  if (!initialized_) return EkfFuseStatus::kNotInitialized;
  if (!std::isfinite(t)) {
    ++counters_.invalid_inputs;
    return EkfFuseStatus::kInvalidInput;
  }
  // A frame boundary before the filter time (a newer measurement is already in) is not logged;
  // neither is a repeated boundary at the same time. Otherwise the marker is logged even when
  // t == time_ (signals stamped at the frame time), so every frame gets its snapshot.
  if (t < time_) return EkfFuseStatus::kFused;
  if (log_size_ > 0 && log_[log_size_ - 1].type == EkfEventType::kFrame && log_[log_size_ - 1].t == t) {
    return EkfFuseStatus::kFused;
  }
  Event e;
  e.t = t;
  e.type = EkfEventType::kFrame;
  return submit(e);
}

EkfFuseStatus Ekf::submit(const Event& e) {
  if (!initialized_) return EkfFuseStatus::kNotInitialized;
  bool finite = std::isfinite(e.t);
  for (int i = 0; i < 4; ++i) {
    finite = finite && std::isfinite(e.z[i]);
    for (int j = 0; j < 4; ++j) finite = finite && std::isfinite(e.R[i][j]);
  }
  if (!finite) {
    ++counters_.invalid_inputs;
    return EkfFuseStatus::kInvalidInput;
  }
  ++counters_.events;

  if (e.t >= time_) {  // in sequence: append and apply
    make_room_in_log();
    log_[log_size_++] = e;
    const EkfFuseStatus status = apply(e);
    if (e.type == EkfEventType::kFrame) take_snapshot(log_size_);
    return status;
  }

  // Out of sequence: insert in time order (after events with the same stamp), roll back, replay.
  make_room_in_log();
  if (snap_count_ == 0 || e.t < snapshots_[snap_first_].t) {
    ++counters_.too_late;
    return EkfFuseStatus::kTooLate;
  }
  std::size_t pos = log_size_;
  while (pos > 0 && log_[pos - 1].t > e.t) --pos;  // bounded by the log capacity
  for (std::size_t j = log_size_; j > pos; --j) log_[j] = log_[j - 1];
  log_[pos] = e;
  ++log_size_;
  for (std::size_t k = 0; k < snap_count_; ++k) {
    Snapshot& s = snapshots_[(snap_first_ + k) % config::kEkfHistoryLength];
    if (s.log_pos > pos) ++s.log_pos;
  }
  // Latest snapshot that does not include the new event.
  std::size_t base = 0;
  for (std::size_t k = 0; k < snap_count_; ++k) {
    if (snapshots_[(snap_first_ + k) % config::kEkfHistoryLength].log_pos <= pos) base = k;
  }
  const Snapshot& from = snapshots_[(snap_first_ + base) % config::kEkfHistoryLength];
  x_ = from.x;
  P_ = from.P;
  gyro_chain_ = from.gyro;
  odometry_chain_ = from.odometry;
  time_ = from.t;
  ++counters_.late_events;
  EkfFuseStatus status = EkfFuseStatus::kFused;
  replaying_ = true;
  std::size_t next_snap = base + 1;
  for (std::size_t j = from.log_pos; j < log_size_; ++j) {
    const EkfFuseStatus s = apply(log_[j]);
    if (j == pos) status = s;
    else ++counters_.replayed_events;
    if (next_snap < snap_count_) {
      Snapshot& sn = snapshots_[(snap_first_ + next_snap) % config::kEkfHistoryLength];
      if (sn.log_pos == j + 1) {
        sn.x = x_;
        sn.P = P_;
        sn.gyro = gyro_chain_;
        sn.odometry = odometry_chain_;
        ++next_snap;
      }
    }
  }
  replaying_ = false;
  // Counters of the late event itself (apply() counts only outside replay).
  if (status == EkfFuseStatus::kFused) {
    if (e.type == EkfEventType::kGnss) ++counters_.gnss_fused;
    if (e.type == EkfEventType::kRegistration) ++counters_.registration_fused;
    if (e.type == EkfEventType::kOdometry) ++counters_.odometry_fused;
    if (e.type == EkfEventType::kVehicleSignals || e.type == EkfEventType::kWheelSpeed) ++counters_.signals_fused;
    if (e.type == EkfEventType::kGyro) ++counters_.gyro_fused;
    if (e.type == EkfEventType::kGyroBiasReset) ++counters_.gyro_bias_resets;
  } else if (status == EkfFuseStatus::kRejectedGate) {
    if (e.type == EkfEventType::kGnss) ++counters_.gnss_rejected;
    if (e.type == EkfEventType::kRegistration) ++counters_.registration_rejected;
    if (e.type == EkfEventType::kGyro) ++counters_.gyro_rejected;
  }
  return status;
}

void Ekf::propagate(double t) {
  const double dt = t - time_;
  if (!(dt > 0.0)) return;
  double n = std::ceil(dt / params_.max_substep);
  if (n < 1.0) n = 1.0;
  if (n > static_cast<double>(config::kEkfMaxPredictSubsteps)) {
    n = static_cast<double>(config::kEkfMaxPredictSubsteps);
    if (!replaying_) ++counters_.substep_caps;
  }
  const int steps = static_cast<int>(n);
  const double h = dt / n;
  const EkfNoise& q = params_.noise;
  for (int k = 0; k < steps; ++k) {
    const double v = x_(idx::kSpeed), w = x_(idx::kYawRate), g = x_(idx::kRoadGrade);
    const double yaw_mid = x_(idx::kYaw) + 0.5 * w * h;
    const double c = det::cos(yaw_mid), s = det::sin(yaw_mid);
    x_(idx::kPosX) += v * h * c;
    x_(idx::kPosY) += v * h * s;
    x_(idx::kPosZ) += v * h * g;
    x_(idx::kYaw) = det::wrap_pi(x_(idx::kYaw) + w * h);
    gyro_chain_.integrated += w * h;

    EkfCovariance F = EkfCovariance::Identity();
    F(idx::kPosX, idx::kYaw) = -v * h * s;
    F(idx::kPosX, idx::kSpeed) = h * c;
    F(idx::kPosX, idx::kYawRate) = -v * h * s * 0.5 * h;
    F(idx::kPosY, idx::kYaw) = v * h * c;
    F(idx::kPosY, idx::kSpeed) = h * s;
    F(idx::kPosY, idx::kYawRate) = v * h * c * 0.5 * h;
    F(idx::kPosZ, idx::kSpeed) = h * g;
    F(idx::kPosZ, idx::kRoadGrade) = v * h;
    F(idx::kYaw, idx::kYawRate) = h;
    // lazyProduct: coefficient-wise products; Eigen's GEMM path for these sizes would reference malloc.
    const EkfCovariance FP = F.lazyProduct(P_);
    P_ = FP.lazyProduct(F.transpose());
    P_(idx::kPosX, idx::kPosX) += q.lateral * q.lateral * h;
    P_(idx::kPosY, idx::kPosY) += q.lateral * q.lateral * h;
    P_(idx::kPosZ, idx::kPosZ) += q.vertical * q.vertical * h;
    P_(idx::kSpeed, idx::kSpeed) += q.accel * q.accel * h;
    P_(idx::kYawRate, idx::kYawRate) += q.yaw_accel * q.yaw_accel * h;
    P_(idx::kYawRateBias, idx::kYawRateBias) += q.yaw_rate_bias * q.yaw_rate_bias * h;
    P_(idx::kWheelScale, idx::kWheelScale) += q.wheel_scale * q.wheel_scale * h;
    P_(idx::kGyroBias, idx::kGyroBias) += q.gyro_bias_walk * q.gyro_bias_walk * h;
    P_(idx::kGyroScale, idx::kGyroScale) += q.gyro_scale_walk * q.gyro_scale_walk * h;
    P_(idx::kRoadGrade, idx::kRoadGrade) += q.road_grade_walk * q.road_grade_walk * h;
    P_ = 0.5 * (P_ + P_.transpose());
  }
  time_ = t;
}

template <int M>
EkfFuseStatus Ekf::fuse(const Eigen::Matrix<double, M, 1>& y,
                        const Eigen::Matrix<double, M, kEkfStateSize>& H,
                        const Eigen::Matrix<double, M, M>& R, double nis_threshold) {
  using MatM = Eigen::Matrix<double, M, M>;
  const Eigen::Matrix<double, M, kEkfStateSize> HP = H.lazyProduct(P_);
  const MatM S = HP.lazyProduct(H.transpose()) + R;
  const Eigen::LLT<MatM> llt(S);
  if (llt.info() != Eigen::Success || !S.allFinite()) {
    if (!replaying_) ++counters_.numeric_failures;
    return EkfFuseStatus::kNumericFailure;
  }
  // S is at most 4x4 and positive definite here: Eigen's closed-form inverse (no heap path).
  const MatM S_inv = S.inverse();
  const double nis = y.dot(S_inv.lazyProduct(y));
  if (nis_threshold > 0.0 && nis > nis_threshold) return EkfFuseStatus::kRejectedGate;
  // K = P H^T S^-1 = (H P)^T S^-1, P symmetric.
  const Eigen::Matrix<double, kEkfStateSize, M> K = HP.transpose().lazyProduct(S_inv);
  x_ += K.lazyProduct(y);
  x_(idx::kYaw) = det::wrap_pi(x_(idx::kYaw));
  // Joseph form: stays symmetric positive semi-definite under rounding (Bucy & Joseph 1968).
  const EkfCovariance I_KH = EkfCovariance::Identity() - K.lazyProduct(H);
  const EkfCovariance A = I_KH.lazyProduct(P_);
  const Eigen::Matrix<double, kEkfStateSize, M> KR = K.lazyProduct(R);
  P_ = A.lazyProduct(I_KH.transpose()) + KR.lazyProduct(K.transpose());
  P_ = 0.5 * (P_ + P_.transpose());
  return EkfFuseStatus::kFused;
}

EkfFuseStatus Ekf::apply(const Event& e) {
  propagate(e.t);
  const bool count = !replaying_;
  switch (e.type) {
    case EkfEventType::kFrame:
      return EkfFuseStatus::kFused;
    case EkfEventType::kWheelSpeed:
    case EkfEventType::kGyro:
    case EkfEventType::kGyroBiasReset:
    case EkfEventType::kRoadGrade:
      return apply_scalar(e, count);
    case EkfEventType::kVehicleSignals: {
      Eigen::Matrix<double, 2, 1> y;
      y << e.z[0] - x_(idx::kWheelScale) * x_(idx::kSpeed),
          e.z[1] - (x_(idx::kYawRate) + x_(idx::kYawRateBias));
      Eigen::Matrix<double, 2, kEkfStateSize> H = Eigen::Matrix<double, 2, kEkfStateSize>::Zero();
      H(0, idx::kSpeed) = x_(idx::kWheelScale);
      H(0, idx::kWheelScale) = x_(idx::kSpeed);
      H(1, idx::kYawRate) = 1.0;
      H(1, idx::kYawRateBias) = 1.0;
      Eigen::Matrix<double, 2, 2> R = Eigen::Matrix<double, 2, 2>::Zero();
      R(0, 0) = e.R[0][0];
      R(1, 1) = e.R[1][1];
      const EkfFuseStatus s = fuse<2>(y, H, R, 0.0);
      if (count && s == EkfFuseStatus::kFused) ++counters_.signals_fused;
      return s;
    }
    case EkfEventType::kOdometry:
      return apply_odometry(e, count);
    case EkfEventType::kGnss: {
      Eigen::Matrix<double, 3, 1> y;
      y << e.z[0] - x_(idx::kPosX), e.z[1] - x_(idx::kPosY), e.z[2] - x_(idx::kPosZ);
      Eigen::Matrix<double, 3, kEkfStateSize> H = Eigen::Matrix<double, 3, kEkfStateSize>::Zero();
      H(0, idx::kPosX) = H(1, idx::kPosY) = H(2, idx::kPosZ) = 1.0;
      Eigen::Matrix<double, 3, 3> R;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) R(r, c) = e.R[r][c];
      const double gate =
          params_.gates.gnss_gate_enabled ? params_.gates.gnss_nis_threshold : 0.0;
      const EkfFuseStatus s = fuse<3>(y, H, R, gate);
      if (count && s == EkfFuseStatus::kFused) ++counters_.gnss_fused;
      if (count && s == EkfFuseStatus::kRejectedGate) ++counters_.gnss_rejected;
      return s;
    }
    case EkfEventType::kRegistration: {
      Eigen::Matrix<double, 4, 1> y;
      y << e.z[0] - x_(idx::kPosX), e.z[1] - x_(idx::kPosY), e.z[2] - x_(idx::kPosZ),
          det::wrap_pi(e.z[3] - x_(idx::kYaw));
      Eigen::Matrix<double, 4, kEkfStateSize> H = Eigen::Matrix<double, 4, kEkfStateSize>::Zero();
      H(0, idx::kPosX) = H(1, idx::kPosY) = H(2, idx::kPosZ) = H(3, idx::kYaw) = 1.0;
      Mat4x4 R;
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) R(r, c) = e.R[r][c];
      const double gate = params_.gates.registration_gate_enabled
                              ? params_.gates.registration_nis_threshold
                              : 0.0;
      const EkfFuseStatus s = fuse<4>(y, H, R, gate);
      if (count && s == EkfFuseStatus::kFused) ++counters_.registration_fused;
      if (count && s == EkfFuseStatus::kRejectedGate) ++counters_.registration_rejected;
      return s;
    }
  }
  return EkfFuseStatus::kInvalidInput;
}

// The one-dimensional events, already propagated to e.t: the wheel speed alone, the gyro z, the
// gyro bias variance reset.
EkfFuseStatus Ekf::apply_scalar(const Event& e, bool count) {
  Eigen::Matrix<double, 1, 1> y;
  Eigen::Matrix<double, 1, kEkfStateSize> H = Eigen::Matrix<double, 1, kEkfStateSize>::Zero();
  Eigen::Matrix<double, 1, 1> R;
  R(0, 0) = e.R[0][0];
  if (e.type == EkfEventType::kGyroBiasReset) {
    P_.row(idx::kGyroBias).setZero();
    P_.col(idx::kGyroBias).setZero();
    P_(idx::kGyroBias, idx::kGyroBias) = e.R[0][0];
    if (count) ++counters_.gyro_bias_resets;
    return EkfFuseStatus::kFused;
  }
  if (e.type == EkfEventType::kRoadGrade) {
    y(0) = e.z[0] - x_(idx::kRoadGrade);
    H(0, idx::kRoadGrade) = 1.0;
    const EkfFuseStatus s = fuse<1>(y, H, R, 0.0);
    if (count && s == EkfFuseStatus::kFused) ++counters_.grade_fused;
    return s;
  }
  if (e.type == EkfEventType::kWheelSpeed) {
    y(0) = e.z[0] - x_(idx::kWheelScale) * x_(idx::kSpeed);
    H(0, idx::kSpeed) = x_(idx::kWheelScale);
    H(0, idx::kWheelScale) = x_(idx::kSpeed);
    const EkfFuseStatus s = fuse<1>(y, H, R, 0.0);
    if (count && s == EkfFuseStatus::kFused) ++counters_.signals_fused;
    return s;
  }
  const double gain = 1.0 + x_(idx::kGyroScale);
  y(0) = e.z[0] - (gain * x_(idx::kYawRate) + x_(idx::kGyroBias));
  H(0, idx::kYawRate) = gain;
  H(0, idx::kGyroBias) = 1.0;
  H(0, idx::kGyroScale) = x_(idx::kYawRate);
  const double gate = params_.gates.gyro_gate_enabled ? params_.gates.gyro_nis_threshold : 0.0;
  const EkfFuseStatus s = fuse<1>(y, H, R, gate);
  if (count && s == EkfFuseStatus::kFused) ++counters_.gyro_fused;
  if (count && s == EkfFuseStatus::kRejectedGate) ++counters_.gyro_rejected;
  const double span = e.z[1];
  if (s != EkfFuseStatus::kFused) {
    gyro_chain_.linked = false;
    return s;
  }
  // The span continues the last one (1 us: the intake's stamps are differences of the same doubles).
  if (gyro_chain_.linked && std::fabs((e.t - span) - gyro_chain_.t) <= 1e-6) {
    const double g = 1.0 + x_(idx::kGyroScale);
    const double rate = (e.z[0] - x_(idx::kGyroBias)) / g;
    x_(idx::kYaw) = det::wrap_pi(x_(idx::kYaw) + (rate * span - gyro_chain_.integrated));
    // Its error: the held rate's share leaves it (-span dw), the bias's and the scale's enter
    // (-span / g db, -span rate / g ds), and the gyro mean's white noise over the span (R span^2 / g^2).
    EkfCovariance J = EkfCovariance::Identity();
    J(idx::kYaw, idx::kYawRate) = -span;
    J(idx::kYaw, idx::kGyroBias) = -span / g;
    J(idx::kYaw, idx::kGyroScale) = -span * rate / g;
    const EkfCovariance JP = J.lazyProduct(P_);
    P_ = JP.lazyProduct(J.transpose());
    P_(idx::kYaw, idx::kYaw) += e.R[0][0] * span * span / (g * g);
    P_ = 0.5 * (P_ + P_.transpose());
  }
  gyro_chain_ = {true, e.t, 0.0};
  return s;
}

// One odometry frame, already propagated to e.t: its mean speed now; its yaw change into the
// window's sum, and at the window's end the sum against the yaw's change since the clone.
EkfFuseStatus Ekf::apply_odometry(const Event& e, bool count) {
  const double dt = e.z[2];
  Eigen::Matrix<double, 2, 1> rate;
  rate << e.z[0] - x_(idx::kSpeed), e.z[1] / dt - x_(idx::kYawRate);
  Eigen::Matrix<double, 2, kEkfStateSize> H2 = Eigen::Matrix<double, 2, kEkfStateSize>::Zero();
  H2(0, idx::kSpeed) = 1.0;
  H2(1, idx::kYawRate) = 1.0;
  Eigen::Matrix<double, 2, 2> R2 = Eigen::Matrix<double, 2, 2>::Zero();
  R2(0, 0) = e.R[0][0];
  R2(1, 1) = e.R[1][1];
  const double rate_gate = params_.gates.odometry_gate_enabled ? params_.gates.odometry_nis_threshold : 0.0;
  const EkfFuseStatus s = fuse<2>(rate, H2, R2, rate_gate);
  if (count && s == EkfFuseStatus::kFused) ++counters_.odometry_fused;
  if (count && s == EkfFuseStatus::kRejectedGate) ++counters_.odometry_rejected;

  // The frame continues the chain (1 us: the frames' stamps are differences of the same doubles).
  OdometryChain& c = odometry_chain_;
  if (!c.linked || std::fabs((e.t - dt) - c.t) > 1e-6) {
    clone_anchor(e.t);
    return s;
  }
  if (params_.noise.anchor_span > 0.0) {
    // Anchored once the filter has converged: the anchor taken then carries its accuracy forward.
    const double arm = params_.noise.anchor_arm_sigma;
    if (!c.armed && 0.5 * (P_(idx::kPosX, idx::kPosX) + P_(idx::kPosY, idx::kPosY)) <= arm * arm) {
      c.armed = true;
      clone_anchor(e.t);
      return s;
    }
    if (c.armed) {
      const EkfFuseStatus a = apply_anchor(e, count);
      return s == EkfFuseStatus::kFused ? a : s;
    }
  }
  c.yaw += e.z[1];
  c.t = e.t;
  if (e.t - c.start < params_.noise.odometry_window - 1e-6) return s;
  Eigen::Matrix<double, 1, 1> y, R;
  Eigen::Matrix<double, 1, kEkfStateSize> H = Eigen::Matrix<double, 1, kEkfStateSize>::Zero();
  y(0) = det::wrap_pi(c.yaw - det::wrap_pi(x_(idx::kYaw) - x_(idx::kAnchorYaw)));
  H(0, idx::kYaw) = 1.0;
  H(0, idx::kAnchorYaw) = -1.0;
  const double turned = params_.noise.odometry_yaw_per_rad * c.yaw;
  R(0, 0) = e.R[2][2] + turned * turned;
  const double gate = params_.gates.odometry_gate_enabled ? params_.gates.window_nis_threshold : 0.0;
  const EkfFuseStatus w = fuse<1>(y, H, R, gate);
  if (count && w == EkfFuseStatus::kFused) ++counters_.odometry_windows_fused;
  if (count && w == EkfFuseStatus::kRejectedGate) ++counters_.odometry_windows_rejected;
  clone_anchor(e.t);
  return s == EkfFuseStatus::kFused ? w : s;
}

void Ekf::clone_anchor(double t) {
  const int from[3] = {idx::kYaw, idx::kPosX, idx::kPosY};
  const int to[3] = {idx::kAnchorYaw, idx::kAnchorX, idx::kAnchorY};
  for (int k = 0; k < 3; ++k) {
    x_(to[k]) = x_(from[k]);
    P_.row(to[k]) = P_.row(from[k]);
    P_.col(to[k]) = P_.col(from[k]);
  }
  const bool armed = odometry_chain_.armed;
  odometry_chain_ = {true, t, t, 0.0, 0.0, 0.0, armed, 0};
}

// Anchored odometry: the odometry's pose since the anchor (composed frame by frame, in the
// anchor's body frame) against the filter's pose relative to the anchor clone, every frame.
// h = [R(-yaw_a) (p - p_a); yaw - yaw_a]. The anchor drifts as the odometry's map does (process
// noise per metre driven); the frame's own error is white (anchor_position, odometry_yaw).
EkfFuseStatus Ekf::apply_anchor(const Event& e, bool count) {
  const EkfNoise& q = params_.noise;
  OdometryChain& c = odometry_chain_;
  const double dt = e.z[2];
  // The step in the body frame, forward along the road's slope: its horizontal share (the planar
  // pose is horizontal; on a 5 % grade the forward step is 0.125 % longer, 15 cm over 120 m).
  const double g = x_(idx::kRoadGrade);
  const double dx = e.z[0] * dt / std::sqrt(1.0 + g * g), dy = e.z[3], dyaw = e.z[1];
  const double cc = det::cos(c.yaw), sc = det::sin(c.yaw);
  c.x += cc * dx - sc * dy;
  c.y += sc * dx + cc * dy;
  c.yaw += dyaw;
  c.t = e.t;
  const double dist = std::sqrt(dx * dx + dy * dy);
  P_(idx::kAnchorX, idx::kAnchorX) += q.anchor_drift * q.anchor_drift * dist;
  P_(idx::kAnchorY, idx::kAnchorY) += q.anchor_drift * q.anchor_drift * dist;
  P_(idx::kAnchorYaw, idx::kAnchorYaw) += q.anchor_yaw_drift * q.anchor_yaw_drift * dist;

  const double ya = x_(idx::kAnchorYaw);
  const double ca = det::cos(ya), sa = det::sin(ya);
  const double px = x_(idx::kPosX) - x_(idx::kAnchorX), py = x_(idx::kPosY) - x_(idx::kAnchorY);
  const double hx = ca * px + sa * py, hy = -sa * px + ca * py;
  Eigen::Matrix<double, 3, 1> y;
  y << c.x - hx, c.y - hy, det::wrap_pi(c.yaw - det::wrap_pi(x_(idx::kYaw) - ya));
  Eigen::Matrix<double, 3, kEkfStateSize> H = Eigen::Matrix<double, 3, kEkfStateSize>::Zero();
  H(0, idx::kPosX) = ca;
  H(0, idx::kPosY) = sa;
  H(0, idx::kAnchorX) = -ca;
  H(0, idx::kAnchorY) = -sa;
  H(0, idx::kAnchorYaw) = hy;
  H(1, idx::kPosX) = -sa;
  H(1, idx::kPosY) = ca;
  H(1, idx::kAnchorX) = sa;
  H(1, idx::kAnchorY) = -ca;
  H(1, idx::kAnchorYaw) = -hx;
  H(2, idx::kYaw) = 1.0;
  H(2, idx::kAnchorYaw) = -1.0;
  Eigen::Matrix<double, 3, 3> R = Eigen::Matrix<double, 3, 3>::Zero();
  const double turned = q.odometry_yaw_per_rad * c.yaw;
  const double swung = q.anchor_position_per_rad * c.yaw;
  R(0, 0) = R(1, 1) = q.anchor_position * q.anchor_position + swung * swung;
  R(2, 2) = e.R[2][2] + turned * turned;
  const double gate = params_.gates.odometry_gate_enabled ? params_.gates.anchor_nis_threshold : 0.0;
  const EkfFuseStatus w = fuse<3>(y, H, R, gate);
  if (count && w == EkfFuseStatus::kFused) ++counters_.odometry_anchor_fused;
  if (count && w == EkfFuseStatus::kRejectedGate) ++counters_.odometry_anchor_rejected;
  // A refused frame is either the odometry slipping or the filter drifting (a gyro bias step turns
  // its yaw): the anchor is kept, as re-anchoring on a drifted filter would hold its error, and
  // taken again only when the refusals persist (the odometry's chain itself slipped).
  const bool refused = w == EkfFuseStatus::kRejectedGate;
  const bool failed = w != EkfFuseStatus::kFused && !refused;  // numeric failure: no anchor to keep
  c.refused = refused ? c.refused + 1 : 0;
  if (failed || c.refused >= params_.gates.anchor_max_refused || e.t - c.start >= q.anchor_span - 1e-6) {
    clone_anchor(e.t);
  }
  return w;
}

void Ekf::take_snapshot(std::size_t log_pos) {
  if (snap_count_ == config::kEkfHistoryLength) {
    drop_oldest_snapshot();
    log_pos = log_size_;  // the log was shifted; a new snapshot always covers the whole log
  }
  Snapshot& s = snapshots_[(snap_first_ + snap_count_) % config::kEkfHistoryLength];
  s.t = time_;
  s.log_pos = log_pos;
  s.x = x_;
  s.P = P_;
  s.gyro = gyro_chain_;
  s.odometry = odometry_chain_;
  ++snap_count_;
}

void Ekf::drop_oldest_snapshot() {
  if (snap_count_ == 0) return;
  snap_first_ = (snap_first_ + 1) % config::kEkfHistoryLength;
  --snap_count_;
  if (snap_count_ == 0) {
    log_size_ = 0;
    return;
  }
  // Events before the new oldest snapshot can never be replayed again: drop them.
  const std::size_t shift = snapshots_[snap_first_].log_pos;
  for (std::size_t j = shift; j < log_size_; ++j) log_[j - shift] = log_[j];
  log_size_ -= shift;
  for (std::size_t k = 0; k < snap_count_; ++k) {
    snapshots_[(snap_first_ + k) % config::kEkfHistoryLength].log_pos -= shift;
  }
}

bool Ekf::make_room_in_log() {
  if (log_size_ < config::kEkfEventLogCapacity) return true;
  ++counters_.history_overflows;
  while (log_size_ >= config::kEkfEventLogCapacity && snap_count_ > 1) drop_oldest_snapshot();
  if (log_size_ < config::kEkfEventLogCapacity) return true;
  // A single snapshot and a full log (no frame markers for a long time): rebase on the current
  // state; rollback then reaches back only to now.
  snap_count_ = 0;
  log_size_ = 0;
  take_snapshot(0);
  return true;
}

}  // namespace v2xloc
