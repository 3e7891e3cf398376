// The one owner of the pose EKF (PX4 EKF2's habit: every aiding source enters through one
// component). It holds the main filter, the validity gates (fixed-lag or causal for the map
// registration, causal for stereo), the ring of registrations waiting for the fixed-lag
// decision, the NIS-rejection count that restarts the filter at a registration, the GNSS
// divergence monitor and the count of frames without a fused registration.
// The optional shadow filter takes every ok registration without the validity gate (the
// evaluator's "Fused (ungated)" column); with PoseFilterParams::shadow_ungated_filter off it is
// never touched.
#pragma once

#include <cstdint>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/ekf.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"
#include "v2xloc/algo/localization/validity_gate.hpp"
#include "v2xloc/algo/registration/registration_result.hpp"

namespace v2xloc {

// One frame's registration handed to the filter.
struct FrameRegistration {
  std::uint32_t frame = 0;          // localizer frame index
  double t = 0.0;                   // [s] frame time
  RegistrationResult result{};
  bool attempted_ok = false;        // false: reported, but neither gated nor fused
  bool withheld = false;            // gated (shapes the envelopes) but neither valid nor fused
  bool no_data = false;             // the sweep had no points: not a failure (max_failed_frames)
  Pose3d odom_T_body = Pose3d::Identity();  // this frame's odometry (carries late restarts)
  VehicleMotion vehicle{};          // speed and yaw rate for a restart
};

// What the validity gate and the EKF made of it.
struct RegistrationFusion {
  bool fused = false;               // this frame's (or, fixed-lag, an earlier frame's) registration
  bool gate_decided = false;        // a gate decision became available ...
  std::uint32_t gate_decided_frame = 0;  // ... for this frame ...
  bool gate_decided_valid = false;  // ... and this is it
};

enum class GnssFusion : std::uint8_t { kIgnored, kFused, kDiverged };

class PoseFilter {
 public:
  // use_vehicle_signals: wheel speed and yaw rate are fused.
  void configure(const PoseFilterParams& params, bool use_vehicle_signals);

  bool initialized() const { return ekf_.initialized(); }
  const Ekf& ekf() const { return ekf_; }
  Pose3d pose() const { return ekf_.state().pose(); }
  Pose3d shadow_pose() const { return shadow_.state().pose(); }
  bool has_shadow() const { return params_.shadow_ungated_filter; }  // the ungated shadow filter runs
  double sigma_xy() const;  // [m] horizontal 1-sigma of the main filter
  // Tracking continues from the prediction while the filter is tight and fuses registrations.
  bool can_track() const;
  // A start-up solution (re)starts the filter: it is not running or has stopped fusing.
  bool needs_start() const { return !ekf_.initialized() || failed_frames_ > params_.max_failed_frames; }

  // The CAN yaw rate is left out while the gyro is live unless filter.imu.can_yaw_rate_with_gyro;
  // while it is live the two are compared (a gyro bias step restarts the bias's variance).
  void on_vehicle(double t, double wheel_speed, double yaw_rate);
  // IMU gyro z, mean rate over span ending at t (imu_intake.hpp); filter.imu.reset_after_rejections
  // NIS rejections in a row restart the gyro bias's variance.
  void on_gyro(double t, double rate, double span, LocalizerCounters& counters);
  // A gyro measurement was fused within filter.imu.live_window before t (the CAN yaw rate's stand-in).
  bool gyro_live(double t) const { return have_gyro_ && t - last_gyro_t_ <= params_.imu.live_window; }
  // A raw gyro z rate [rad/s] less the filter's bias, over its scale (as is before the filter runs).
  double corrected_gyro_rate(double raw) const {
    if (!ekf_.initialized()) return raw;
    const EkfState s = ekf_.state();
    return (raw - s.gyro_bias) / (1.0 + s.gyro_scale);
  }
  // kDiverged: gnss_divergence_fixes fixes in a row far from the filter (the caller loses track).
  GnssFusion on_gnss(double t, const Vec3d& enu, double h_acc, double v_acc);
  void on_odometry(double t, double dt, const Mat4d& body_delta);
  void on_road_grade(double t, double grade);
  void predict_to(double t);

  // Starts both filters at a confirmed start-up pose.
  void start(double t, const Pose3d& pose, const VehicleMotion& vehicle);
  // Where a confirmed start-up begins: the confirming registration and the candidate it confirmed
  // (carried to the same frame) are two estimates of one pose; their mean weighted by the
  // registrations' covariances (x, y, z, yaw; roll and pitch the confirmation's). The
  // confirmation's own pose when the candidate carries no information.
  Pose3d start_pose(const RegistrationResult& confirmation, const RegistrationResult& candidate) const;
  // A start-up pose may restart the filter: it is not running, or the pose lies inside its belief
  // (PoseFilterParams::reacquire_*).
  bool accepts_restart_at(const Pose3d& pose) const;
  // Tracking is lost (GNSS divergence or basin audit): everything starts over.
  void lose_track();
  // A frame that produced no registration to gate counts towards max_failed_frames (a frame
  // without data does not: FrameRegistration::no_data).
  void count_failed_frame() { ++failed_frames_; }

  // Validity gate -> EKF (fixed-lag: a registration is fused w/2 frames later, at its own stamp
  // through the EKF's history).
  RegistrationFusion fuse(const FrameRegistration& reg, LocalizerCounters& counters);
  // Stereo registration, gated causally, fused at the frame's stamp with a covariance no
  // tighter than its depth noise allows; true when the EKF took it.
  bool fuse_stereo(double t, const RegistrationResult& r, double depth_sigma);

 private:
  struct Pending {
    std::uint32_t frame = 0;       // localizer frame index
    std::uint64_t gate_index = 0;  // push index in the fixed-lag gate
    double t = 0.0;
    Mat4d pose = Mat4d::Identity();
    Mat4d odom = Mat4d::Identity();  // odometry pose at that frame: carries a late restart to now
    PoseCovariance covariance = PoseCovariance::Identity();
    bool ok = false;
    bool withheld = false;  // FrameRegistration::withheld
  };
  static constexpr std::size_t kPendingCapacity = config::kGateMaxWindow;
  struct Now {                     // where a restart lands: this frame
    double t = 0.0;
    Mat4d odom_T_body = Mat4d::Identity();
    VehicleMotion vehicle{};
  };

  enum class Which : std::uint8_t { kMain, kShadow };

  bool fuse_gate_decision(const Pending& reg, const GateSample& sample, const Now& now,
                          RegistrationFusion& out, LocalizerCounters& counters);
  // EKF update; NIS-rejected reset_after_rejections times in a row -> restart at the registration.
  bool fuse_into(Which which, const Pending& reg, const Now& now, LocalizerCounters& counters);
  void restart(Ekf& ekf, double t, const Mat4d& pose, const VehicleMotion& vehicle) const;
  void watch_gyro_against_can(double t, double rate, double span, LocalizerCounters& counters);
  void reset_gyro_bias(double t, LocalizerCounters& counters);

  PoseFilterParams params_{};
  bool use_vehicle_signals_ = true;
  Ekf ekf_{};
  Ekf shadow_{};
  FixedLagValidityGate fixed_lag_gate_{};
  CausalValidityGate causal_gate_{};
  CausalValidityGate stereo_gate_{};
  Pending pending_[kPendingCapacity];
  std::uint64_t gate_pushes_ = 0;
  std::uint32_t failed_frames_ = 0;           // consecutive frames without a fused registration
  std::uint32_t nis_rejections_ = 0;          // consecutive NIS rejections (main filter)
  std::uint32_t nis_rejections_shadow_ = 0;
  std::uint32_t gnss_divergent_fixes_ = 0;
  // The gyro (main filter): last fused measurement, NIS rejections in a row, the recent CAN yaw
  // rates, and the running mean of the gyro's disagreement with them.
  bool have_gyro_ = false;
  double last_gyro_t_ = 0.0;
  struct CanSample {
    double t = 0.0;
    double yaw_rate = 0.0;
  };
  static constexpr std::size_t kCanRing = 16;  // 160 ms of CAN at 100 Hz: a period and its margin
  CanSample can_[kCanRing];
  std::size_t can_next_ = 0;
  std::uint32_t gyro_rejections_ = 0;
  double can_gyro_mean_ = 0.0;
  double can_gyro_t_ = 0.0;
  double can_gyro_since_ = 0.0;  // start of the running mean (it decides after one window)
  bool can_gyro_running_ = false;
};

}  // namespace v2xloc
