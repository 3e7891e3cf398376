// Fixed-size extended Kalman filter for the ego pose (PX4 EKF2's habits: one state struct with a
// documented layout and index table, fixed-size matrices, Joseph-form updates, innovation gates
// with counters, a bounded history for delayed measurements).
//
// State (kEkfStateSize = 14), local ENU frame (x east, y north, z up), with the process noise that
// drives each state (EkfNoise, continuous densities; PX4 EKF2 lists its states and their process
// noise parameters the same way):
//
// | # | state                                    | unit  | process noise (EkfNoise)                  |
// |---|------------------------------------------|-------|-------------------------------------------|
// | 0 | position x of the vehicle reference point| m     | lateral [m/sqrt(s)] (slip, model error)   |
// | 1 | position y                               | m     | lateral                                   |
// | 2 | position z                               | m     | vertical [m/sqrt(s)] (model error)        |
// | 3 | yaw, body x from east, wrapped (-pi, pi] | rad   | none: integrates the yaw rate             |
// | 4 | forward speed along body x               | m/s   | accel [m/s^2/sqrt(Hz)]                    |
// | 5 | yaw rate                                 | rad/s | yaw_accel [rad/s^2/sqrt(Hz)]              |
// | 6 | CAN yaw-rate sensor bias (z = w + b)     | rad/s | yaw_rate_bias [rad/s/sqrt(s)]             |
// | 7 | wheel-speed scale (z = k v)              | -     | wheel_scale [1/sqrt(s)]                   |
// | 8 | IMU gyro z bias (z = (1 + s_g) w + b_g)  | rad/s | gyro_bias_walk [rad/s/sqrt(s)] (sensor's) |
// | 9 | IMU gyro z scale error s_g               | -     | gyro_scale_walk [1/sqrt(s)] (sensor's)    |
// |10 | road grade g along the heading (dz/ds)   | -     | road_grade_walk [1/sqrt(s)] (road design) |
// |11 | yaw at the odometry anchor               | rad   | anchor_yaw_drift [rad/sqrt(m)] when armed |
// |12 | position x at the odometry anchor        | m     | anchor_drift [m/sqrt(m)] when armed       |
// |13 | position y at the odometry anchor        | m     | anchor_drift                              |
//
// Measurements: CAN wheel speed (z = k v) and yaw rate (z = w + b), the IMU gyro z
// (z = (1 + s_g) w + b_g, noise from the sensor's angle random walk gyro_noise_density:
// sigma^2 = N^2 / span for the mean rate over span seconds), GNSS position, registration pose
// (x, y, z, yaw), LiDAR odometry (the frame's mean speed and yaw rate; its pose since an anchor),
// the road grade (the body's pitch, ground_attitude.hpp).
// The scale error s_g is what a turn adds to the gyro's error beyond its bias (a MEMS part's
// sensitivity error, 0.5 % 1 sigma for the class): without it
// the registrations' yaw corrections during a turn land in the bias, which is then wrong on the
// straight that follows; with it the turn's share goes to the state it belongs to.
// Process model: constant turn rate and velocity on the ground plane (Schubert et al. 2008,
// CTRV), midpoint-yaw integration, climbing at the road grade (z' = v g: on a 5 % street at 6 m/s
// z changes 0.3 m/s, which a random-walk z follows only with a lag); z, speed, yaw rate, biases,
// scale and grade are random walks.
// Without gyro measurements states 8 and 9 have no cross-covariance with states 0-7 and never
// touch them.
//
// Design choice: the vehicle's wheel speed and yaw rate, and the IMU's gyro z, are fused as
// measurements of the speed and yaw-rate states (z = k v, z = w + b, z = (1 + s_g) w + b_g) at their
// own rate, and prediction integrates those states (the gyro, fused every ~10 ms with a noise far below
// the CAN signal's, is what the yaw-rate state follows, so the yaw is the integrated gyro, less its
// bias, over its scale).
// Compared with feeding them as control inputs this (a) makes wheel scale and gyro biases
// observable from every absolute fix, (b) lets LiDAR odometry enter the same way, and (c) turns
// history replay into a pure function of the time-ordered event log, with no separate input
// buffer. Signal noise enters through R, the smoothing bandwidth through the random-walk q's.
// LiDAR odometry's relative pose between two frames (dt apart) is fused as the mean body speed
// and yaw rate over that interval (z = [dp_x / dt, dyaw / dt]), for the speed and yaw-rate states.
// Its yaw changes are also summed over a window (odometry_window) and fused as one relative
// measurement between the yaw at the window's start, kept as a cloned state (stochastic cloning,
// Roumeliotis & Burdick 2002), and the yaw now: z = yaw - yaw_clone. A scan-to-map odometry's
// heading error does not grow from frame to frame (0.012-0.013 deg rms over 1 to 40 frames on the
// recordings), so the window pins the heading's drift, which the per-frame rates cannot: they steer
// only the yaw-rate state, whose errors the filter cannot see cancel over frames. The rates' share
// of a window's yaw change is small (sigma 1.6e-3 rad over 10 frames against the window's 3.5e-4),
// so counting the changes twice is left. The clone is taken again at each window's end, fused or
// rejected, and when the chain of frames breaks (a frame without odometry).
// Anchored odometry, once the filter has converged (position sigma <= anchor_arm_sigma, latched
// until the next initialize()): the clone grows to the whole planar pose (states 11-13, taken
// together) and every frame fuses the odometry's pose since the anchor, composed frame by frame,
// as one 3-DoF measurement, h = [R(-yaw_a) (p - p_a); yaw - yaw_a] (stochastic cloning again). A
// scan-to-map odometry's position error is white from frame to frame (5-8 mm along the track at
// every span from 1 to 100 frames on the recordings) and its map drifts slowly: the frame's error
// is measurement noise (anchor_position, odometry_yaw), the drift a random walk of the anchor per
// metre driven. The filter then remembers each registration for as long as the anchor lives (30 s)
// instead of the ~1 s the position diffusion and the per-frame rates leave it: a bias shared by
// many registrations averages out against the odometry, and a pose stays anchored through a
// spell without registrations. The anchor is taken again after anchor_span, after
// anchor_max_refused frames in a row whose NIS exceeds anchor_nis_threshold (the odometry's chain
// slipped; a single refusal keeps the anchor: a filter that drifted, as on a gyro bias step, must
// not be anchored), and when the chain breaks. Before arming the window above holds the yaw
// alone: an anchor taken while the pose is still converging carries that pose's error forward
// (host, the 12 rows through the firmware: live Fused summed 0.111 m armed at 0.02 m, 0.115 m at
// 0.03 m, 0.128 m armed from the start).
//
// Out-of-sequence measurements: every event (measurement or predict_to() frame marker) is kept in a
// time-ordered log (config::kEkfEventLogCapacity); after each frame marker a snapshot of
// (state, covariance) is stored (config::kEkfHistoryLength frames). A measurement older than the
// filter time is inserted into the log, the filter rolls back to the latest snapshot before it and
// replays the log: the result is bit-identical to on-time fusion of the same event sequence.
// Events older than the oldest snapshot are rejected (counted as too_late).
//
// Size: ~149 kB (event log 512 x 176 B + 32 snapshots x 1,776 B); static storage, not the stack.
#pragma once

#include <cstddef>
#include <cstdint>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/localization/pose_types.hpp"

namespace v2xloc {

inline constexpr int kEkfStateSize = 14;

// Index table of the state vector (EKF2's StateSample indices).
namespace ekf_index {
inline constexpr int kPosX = 0;
inline constexpr int kPosY = 1;
inline constexpr int kPosZ = 2;
inline constexpr int kYaw = 3;
inline constexpr int kSpeed = 4;
inline constexpr int kYawRate = 5;
inline constexpr int kYawRateBias = 6;
inline constexpr int kWheelScale = 7;
inline constexpr int kGyroBias = 8;
inline constexpr int kGyroScale = 9;
inline constexpr int kRoadGrade = 10;
inline constexpr int kAnchorYaw = 11;
inline constexpr int kAnchorX = 12;
inline constexpr int kAnchorY = 13;
}  // namespace ekf_index

using EkfVector = Eigen::Matrix<double, kEkfStateSize, 1>;
using EkfCovariance = Eigen::Matrix<double, kEkfStateSize, kEkfStateSize>;

// The state with names, in index-table order.
struct EkfState {
  double pos_x = 0.0;          // [m] east
  double pos_y = 0.0;          // [m] north
  double pos_z = 0.0;          // [m] up
  double yaw = 0.0;            // [rad]
  double speed = 0.0;          // [m/s]
  double yaw_rate = 0.0;       // [rad/s]
  double yaw_rate_bias = 0.0;  // [rad/s]
  double wheel_scale = 1.0;    // [-]
  double gyro_bias = 0.0;      // [rad/s] IMU gyro z
  double gyro_scale = 0.0;     // [-] IMU gyro z scale error (z = (1 + s) w + b)
  double road_grade = 0.0;     // [-] dz per metre driven
  double anchor_yaw = 0.0;     // [rad] yaw at the odometry anchor / window start (a clone of yaw)
  double anchor_x = 0.0;       // [m] position at the odometry anchor (a clone of pos_x)
  double anchor_y = 0.0;       // [m] (a clone of pos_y)

  EkfVector to_vector() const;
  static EkfState from_vector(const EkfVector& x);
  Vec3d position() const { return {pos_x, pos_y, pos_z}; }
  Pose3d pose() const;  // world_T_body (yaw only; roll = pitch = 0)
};
static_assert(sizeof(EkfState) == kEkfStateSize * sizeof(double), "EkfState layout is the index table");

struct EkfNoise {
  // Process noise as continuous random-walk densities (variance growth per second).
  double accel = 1.0;             // speed random walk [m/s^2/sqrt(Hz)] (urban driving)
  double yaw_accel = 0.3;         // yaw-rate random walk [rad/s^2/sqrt(Hz)]
  double vertical = 0.05;         // z random walk [m/sqrt(s)] (road grade)
  double lateral = 0.02;          // position diffusion [m/sqrt(s)] (slip, model error)
  double yaw_rate_bias = 1e-4;    // CAN yaw-rate sensor bias walk [rad/s/sqrt(s)]
  double wheel_scale = 1e-4;      // scale walk [1/sqrt(s)] (tyre pressure / wear)
  // IMU gyro z, automotive MEMS class (Bosch BMI088 data sheet BST-BMI088-DS001: rate noise density
  // 0.014 deg/s/sqrt(Hz) = 2.44e-4 rad/s/sqrt(Hz), the part the simulator models, host_sim/README.md;
  // an ST ASM330LHH-class part, 5 mdps/sqrt(Hz), would set 8.7e-5), carried at twice the data
  // sheet's: the filter takes each 10 ms mean as the rate at its end and uses it twice (the rate
  // update and the yaw's increment), which the sensor's own figure does not cover (algo/TUNING.md,
  // "Gyro integration and noise"). Bias walk above the class's 2-4 deg/h instability so the bias
  // state follows a warming part (0.015 deg/s/K).
  double gyro_noise_density = 4.88e-4;  // angle random walk [rad/s/sqrt(Hz)]
  double gyro_bias_walk = 2e-5;        // bias random walk [rad/s/sqrt(s)]
  // Sensitivity drift [1/sqrt(s)]: the BMI088's sensitivity temperature drift, 0.03 %/K, over a
  // warming part (a few K in the first minutes) is ~1e-5 per second; a walk of that size per sqrt(s).
  double gyro_scale_walk = 1e-5;
  // Road grade [1/sqrt(s)]: a vertical curve between grades changes them by ~0.5 %/s at city speed
  // (AASHTO crest/sag curves, K = 5-20 m/%); a walk of 0.01/sqrt(s) follows that within a second.
  double road_grade_walk = 0.002;
  // Measurement noise (1 sigma).
  double wheel_speed = 0.05;      // [m/s], incl. quantisation
  double gyro = 0.005;            // [rad/s] CAN yaw rate
  double odometry_speed = 0.05;   // [m/s], LiDAR odometry mean speed over a frame
  // [rad] odometry's yaw change over a window, 1 sigma: its heading error on the recordings is
  // 0.012-0.013 deg rms whatever the window (1-40 frames); 1.5x that, as registrations are
  // inflated (the EMBEDDED profile's odometry, 0.027 deg rms, did no better with 7e-4).
  double odometry_yaw = 3.5e-4;
  double odometry_yaw_rate = 0.005;  // [rad/s] the frame's mean yaw rate, for the yaw-rate state
  double odometry_window = 1.0;   // [s] yaw changes summed before one relative-yaw update
  // [rad/rad] more in proportion to the window's turn: a scan-to-map odometry's heading error grows
  // with rotation (motion distortion, the map's angular resolution); 1 % of a 90 deg turn is 0.9 deg.
  double odometry_yaw_per_rad = 0.01;
  // Anchored odometry (see the header comment; anchor_span 0: off, the yaw window alone).
  double anchor_span = 30.0;       // [s] an anchor's life
  // [m] 1 sigma of a frame's position from the odometry, per axis: about the upper end of its
  // frame-to-frame position error on the recordings, 6.2-7.5 mm rms (host) and 13-23 mm (the
  // EMBEDDED profile's coarser map: 2 points a voxel, odometry.hpp).
  double anchor_position = config::kEmbeddedProfile ? 0.02 : 0.008;
  // [m/rad] more in proportion to the turn since the anchor: a rotation moves the odometry's
  // position by its lever-arm and deskew errors (a few cm over a 90 deg turn); without it the
  // EMBEDDED profile's Fused (valid) on Sim 3's turn rose 1.7-3.0 mm (algo/TUNING.md).
  double anchor_position_per_rad = 0.03;
  // The odometry map's drift as the anchor's random walk per metre driven: 1 mm/sqrt(m) (2.4 mm
  // over 6 m/s x 1 s, ~1 cm over a 100 m anchor) and 6e-5 rad/sqrt(m) (0.034 deg over 100 m).
  double anchor_drift = 0.001;     // [m/sqrt(m)]
  double anchor_yaw_drift = 6e-5;  // [rad/sqrt(m)]
  double anchor_arm_sigma = 0.02;  // [m] armed once the position sigma (x, y mean) first reaches it
};

struct EkfGateParams {
  // GNSS: the reported sigma is multiplied by this before gating and fusing (receivers under-
  // report in urban canyons; 1.0 trusts them).
  double gnss_sigma_inflation = 1.5;
  // NIS thresholds: chi-square 99.9 % quantiles (3 DoF: 16.27, 4 DoF: 18.47). A fix is rejected
  // when y^T S^-1 y exceeds them (multipath outliers, wrong registrations).
  double gnss_nis_threshold = 16.27;
  double registration_nis_threshold = 18.47;
  // LiDAR odometry rates (2 DoF: 13.82) against the wheel speed / gyro the filter already has: a
  // scan match that slipped (e.g. under-rotated at a turn's onset) must not drag the yaw rate.
  double odometry_nis_threshold = 13.82;
  // Its yaw change over a window (1 DoF: 10.83) against the filter's: nor turn the heading.
  double window_nis_threshold = 10.83;
  // The odometry's pose since the anchor (3 DoF: 16.27) against the filter's.
  double anchor_nis_threshold = 16.27;
  // Refused anchored frames in a row before the anchor is taken again (1 s at 10 Hz): a drifted
  // filter comes back within it, the registrations' and the vehicle signals' work; an odometry
  // chain that slipped keeps failing.
  std::uint32_t anchor_max_refused = 10;
  // IMU gyro z (1 DoF: 10.83) against the yaw rate the CAN signal, odometry and registrations hold:
  // a bias step or a stuck axis is rejected instead of turning the yaw.
  double gyro_nis_threshold = 10.83;
  bool gnss_gate_enabled = true;
  bool registration_gate_enabled = true;
  bool odometry_gate_enabled = true;
  bool gyro_gate_enabled = true;
};

struct EkfParams {
  EkfNoise noise{};
  EkfGateParams gates{};
  double max_substep = 0.01;  // [s] prediction step; longer segments are split (<= cap substeps)
};

// How a registration's ICP information matrix becomes a pose covariance.
struct RegistrationCovarianceParams {
  // cov6 = scale * rmse^2 * info^-1 (info = sum J^T J in the ICP's (rx,ry,rz,tx,ty,tz) order).
  // ICP correspondences are not independent (shared voxel, correlated noise), so the textbook
  // covariance is optimistic (Censi 2007; Landry et al. 2019): scale inflates it.
  double scale = 10.0;
  double min_rmse = 0.01;          // [m] floor of the residual sigma (perfect synthetic fits)
  double min_sigma_xy = 0.01;      // [m] floors per axis after marginalisation
  double min_sigma_z = 0.02;       // [m]
  double min_sigma_yaw = 0.002;    // [rad]
};

enum class EkfEventType : std::uint8_t {
  kFrame,          // predict_to() marker; a snapshot follows it
  kVehicleSignals, // wheel speed + yaw rate
  kGnss,
  kRegistration,
  kOdometry,
  kWheelSpeed,     // wheel speed alone (the IMU gyro stands in for the CAN yaw rate)
  kGyro,           // IMU gyro z, mean over a span
  kGyroBiasReset,  // the gyro bias variance restarts (persistent gyro rejections)
  kRoadGrade,      // the body's pitch as the road's grade (z = g)
};

enum class EkfFuseStatus : std::uint8_t {
  kFused,
  kRejectedGate,     // NIS above threshold
  kTooLate,          // older than the oldest snapshot
  kNotInitialized,
  kInvalidInput,     // non-finite value or non-positive-definite covariance
  kNumericFailure,   // innovation covariance not positive definite
};

struct EkfCounters {
  std::uint64_t events = 0;
  std::uint64_t gnss_fused = 0;
  std::uint64_t gnss_rejected = 0;
  std::uint64_t registration_fused = 0;
  std::uint64_t registration_rejected = 0;
  std::uint64_t odometry_fused = 0;     // frames whose speed was fused
  std::uint64_t odometry_rejected = 0;  // frames whose speed the NIS gate refused
  std::uint64_t odometry_windows_fused = 0;     // windows' yaw changes fused
  std::uint64_t odometry_windows_rejected = 0;  // windows' yaw changes the NIS gate refused
  std::uint64_t odometry_anchor_fused = 0;     // frames whose pose since the anchor was fused
  std::uint64_t odometry_anchor_rejected = 0;  // ... refused by the NIS gate
  std::uint64_t grade_fused = 0;
  std::uint64_t signals_fused = 0;      // vehicle signals, with or without their yaw rate
  std::uint64_t gyro_fused = 0;
  std::uint64_t gyro_rejected = 0;      // NIS gate
  std::uint64_t gyro_bias_resets = 0;
  std::uint64_t late_events = 0;        // fused through rollback + replay
  std::uint64_t too_late = 0;           // rejected: older than the history
  std::uint64_t invalid_inputs = 0;
  std::uint64_t numeric_failures = 0;
  std::uint64_t history_overflows = 0;  // event log full: history shortened
  std::uint64_t replayed_events = 0;
  std::uint64_t substep_caps = 0;       // segments longer than kEkfMaxPredictSubsteps * max_substep
};

// Covariance of (x, y, z, yaw) from a registration's 6x6 information, per the params above.
// The ICP twist is left-multiplied about the world origin (registration_result.hpp), so a yaw
// uncertainty also moves the vehicle: the position block is G cov6 G^T with G = [-[p]x | I],
// p = the registered vehicle position (pose translation).
PoseCovariance registration_covariance(const Mat6d& information, double inlier_rmse, const Pose3d& pose,
                                      const RegistrationCovarianceParams& params = {});

class Ekf {
 public:
  explicit Ekf(const EkfParams& params = {});

  // Starts (or restarts) the filter at time t [s]; clears the history.
  void initialize(double t, const EkfState& state, const EkfCovariance& covariance);
  bool initialized() const { return initialized_; }
  // Back to uninitialized (the localizer lost track); the history is dropped, counters are kept,
  // and the last state and covariance stay readable (a restart carries the gyro bias over).
  void reset();

  // Measurements, each at its own time stamp t [s]; t older than the filter time -> rollback.
  EkfFuseStatus on_vehicle_signals(double t, double wheel_speed, double yaw_rate);
  // The wheel speed alone (the CAN yaw rate is left out while the IMU gyro drives the yaw).
  EkfFuseStatus on_wheel_speed(double t, double wheel_speed);
  // IMU gyro z: mean rate [rad/s] over the span [s] ending at t (noise gyro_noise_density^2 / span).
  EkfFuseStatus on_gyro(double t, double rate, double span);
  // The gyro bias variance restarts at sigma^2 [rad/s] with no cross-covariance (its value stays):
  // the next gyro measurements re-estimate it (a bias step the NIS gate kept rejecting).
  EkfFuseStatus reset_gyro_bias(double t, double sigma);
  // GNSS position in local ENU [m] with 1-sigma horizontal / vertical accuracy [m].
  EkfFuseStatus on_gnss(double t, const Vec3d& enu, double sigma_horizontal, double sigma_vertical);
  // Registration pose world_T_body; covariance of (x, y, z, yaw) (see registration_covariance).
  EkfFuseStatus on_registration(double t, const Pose3d& pose, const PoseCovariance& covariance);
  // LiDAR odometry between t - dt and t: relative pose prev_T_curr (body frame). The status is the
  // speed's, or the window's yaw change's when this frame closed a window and the speed was fused.
  EkfFuseStatus on_odometry(double t, double dt, const Pose3d& relative_pose);
  // The road grade along the heading (dz per metre driven), 1-sigma sigma.
  EkfFuseStatus on_road_grade(double t, double grade, double sigma);
  // Propagates to t (a frame boundary) and snapshots the state for later rollbacks.
  EkfFuseStatus predict_to(double t);

  double time() const { return time_; }
  EkfState state() const { return EkfState::from_vector(x_); }
  const EkfVector& state_vector() const { return x_; }
  const EkfCovariance& covariance() const { return P_; }
  const EkfCounters& counters() const { return counters_; }
  const EkfParams& params() const { return params_; }

 private:
  struct Event {
    double t = 0.0;
    EkfEventType type = EkfEventType::kFrame;
    double z[4] = {0.0, 0.0, 0.0, 0.0};
    double R[4][4] = {};
  };
  // The yaw the prediction integrated since the last fused gyro measurement: at the next one that
  // continues it, the yaw takes the gyro's angle over the span instead (mean rate - bias, times the
  // span): the held yaw-rate state lags a turning car by half a step (a zero-order hold), the
  // gyro's average does not. Part of the snapshots, so replay stays a function of the log.
  struct GyroChain {
    bool linked = false;      // t is the end of the last fused gyro span
    double t = 0.0;           // [s]
    double integrated = 0.0;  // [rad] yaw integrated by the prediction since t
  };
  // The odometry frames since the clone (states kAnchorYaw, kAnchorX, kAnchorY) was taken: their
  // yaw changes summed and their poses composed. Part of the snapshots, like GyroChain.
  struct OdometryChain {
    bool linked = false;  // t is the end of the last odometry frame, and the clone is at start
    double start = 0.0;   // [s] when the clone was taken
    double t = 0.0;       // [s]
    double yaw = 0.0;     // [rad] odometry's yaw change from start to t
    double x = 0.0;       // [m] odometry's position since start, in the anchor's body frame
    double y = 0.0;       // [m]
    bool armed = false;   // anchored odometry armed (kept across anchors, cleared by initialize())
    std::uint32_t refused = 0;  // anchored frames refused in a row
  };
  struct Snapshot {
    double t = 0.0;
    std::size_t log_pos = 0;  // first log event NOT reflected in this snapshot
    EkfVector x;
    EkfCovariance P;
    GyroChain gyro;
    OdometryChain odometry;
  };

  EkfFuseStatus submit(const Event& e);
  EkfFuseStatus apply(const Event& e);  // predict to e.t, then fuse e
  EkfFuseStatus apply_scalar(const Event& e, bool count);
  EkfFuseStatus apply_odometry(const Event& e, bool count);
  // States kAnchorYaw, kAnchorX, kAnchorY := yaw, x, y, with their covariance; the chain starts at t.
  void clone_anchor(double t);
  EkfFuseStatus apply_anchor(const Event& e, bool count);
  void propagate(double t);
  template <int M>
  EkfFuseStatus fuse(const Eigen::Matrix<double, M, 1>& innovation,
                     const Eigen::Matrix<double, M, kEkfStateSize>& H,
                     const Eigen::Matrix<double, M, M>& R, double nis_threshold);
  void take_snapshot(std::size_t log_pos);
  void drop_oldest_snapshot();
  bool make_room_in_log();

  EkfParams params_;
  bool initialized_ = false;
  double time_ = 0.0;
  EkfVector x_ = EkfVector::Zero();
  EkfCovariance P_ = EkfCovariance::Zero();
  EkfCounters counters_;
  GyroChain gyro_chain_{};
  OdometryChain odometry_chain_{};
  bool replaying_ = false;

  Event log_[config::kEkfEventLogCapacity];
  std::size_t log_size_ = 0;
  Snapshot snapshots_[config::kEkfHistoryLength];  // ring, oldest at snap_first_
  std::size_t snap_first_ = 0;
  std::size_t snap_count_ = 0;
};

}  // namespace v2xloc
