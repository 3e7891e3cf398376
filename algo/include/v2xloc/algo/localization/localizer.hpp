// The localizer: one object wiring an ego frame through every stage (paper Fig. 1):
//   map clouds (infra/agents) -> map_fusion -> reference map (+normals, k-d tree, FPFH on demand)
//   ego scan -> deskew (wheel speed + yaw rate) -> LiDAR odometry (relative, predicted from the
//   same signals) -> registration to the map -> validity gate -> EKF (wheel speed / yaw rate,
//   GNSS and odometry with NIS gates, valid registrations); optional stereo registration.
// Registration modes: tracking = ICP from the EKF prediction, audited every few frames by a
// local exhaustive search (aliased basins); global = GNSS-seeded exhaustive search + FPFH/RANSAC,
// ambiguities resolved by the GNSS track, and a candidate starts the filter only when a second
// search agrees through the odometry. Lost track (GNSS divergence, audit) -> global again.
// Inputs arrive through on_*() calls in time order per source; the caller decides the event
// order, and the same order gives the same bits (offline evaluator and firmware share it).
// All storage is inside the object (hundreds of MB on the host profile): make it static.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/ekf.hpp"
#include "v2xloc/algo/core/geodesy.hpp"
#include "v2xloc/algo/localization/map_fusion.hpp"
#include "v2xloc/algo/registration/registration_result.hpp"
#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/localization/validity_gate.hpp"
#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/stereo_cloud.hpp"
#include "v2xloc/algo/localization/odometry.hpp"
#include "v2xloc/algo/localization/scan_ingest.hpp"
#include "v2xloc/algo/localization/stage_probe.hpp"
#include "v2xloc/algo/localization/trajectory_backfill.hpp"
#include "v2xloc/algo/registration/register_clouds.hpp"
#include "v2xloc/algo/registration/voxel_downsample.hpp"

namespace v2xloc {

struct VehicleInput {
  double t = 0.0;                // [s] measurement time
  double wheel_speed = 0.0;      // [m/s]
  double yaw_rate = 0.0;         // [rad/s]
};

struct GnssInput {
  double t = 0.0;                // [s]
  double lat_deg = 0.0, lon_deg = 0.0, alt_m = 0.0;
  double h_acc = 10.0;           // [m] receiver-reported 1-sigma horizontal accuracy
  double v_acc = 15.0;           // [m]
  std::uint8_t num_sats = 0;
  double hdop = 99.0;
  bool valid = false;
  // Doppler velocity of the same fix (optional): its course over ground is the only absolute
  // heading the vehicle has before the map registration starts.
  bool velocity_valid = false;
  double vel_east = 0.0, vel_north = 0.0;  // [m/s] local ENU
  double speed_acc = 0.0;                  // [m/s] receiver-reported 1 sigma per axis
};

struct MapCloudInput {
  std::uint32_t source_id = 0;   // stable per sensor (infra unit, agent vehicle)
  bool is_agent = false;         // agents' poses are self-reported (less trusted)
  double t = 0.0;                // [s] capture time
  Mat4d world_T_sensor = Mat4d::Identity();
  std::span<const Vec3f> points{};  // sensor frame
};

// The ego stereo pair's rectified disparity of the same frame (optional).
struct StereoInput {
  std::span<const std::uint16_t> disparity{};  // row-major width x height; raw 0 = no match
  double scale = 1.0 / 256.0;                  // [px] per raw unit (16-bit PNG convention)
  std::uint32_t width = 0, height = 0;
  StereoCalibration calibration{};             // vehicle_T_camera: left camera in the body frame
  double disparity_sigma = 0.0;                // [px] matching noise if known; 0: the params' value
};

struct EgoScanInput {
  double t = 0.0;                // [s] frame time; point times are relative to it
  std::span<const Vec3f> points{};      // LiDAR sensor frame
  std::span<const float> point_times{}; // [s] per point, empty if the sensor has none
  Mat4d body_T_lidar = Mat4d::Identity();
  StereoInput stereo{};          // used when LocalizerParams::use_stereo and disparity is given
};

enum class LocalizationMode : std::uint8_t {
  kUninitialized,  // no GNSS / no map yet
  kGlobalSearch,   // FPFH + RANSAC within the GNSS uncertainty region
  kTracking,       // ICP from the EKF prediction
};

struct LocalizerFrameOutput {
  std::uint32_t frame = 0;
  double t = 0.0;
  LocalizationMode mode = LocalizationMode::kUninitialized;
  // Odometry in its own frame (odom_T_body; the odom frame is the LiDAR frame of the first
  // scan), registration and fused poses (world_T_body).
  Mat4d odometry_pose = Mat4d::Identity();
  bool odometry_ok = false;
  Mat4d registration_pose = Mat4d::Identity();
  Mat4d fused_pose = Mat4d::Identity();           // main filter (gated registrations)
  Mat4d fused_pose_ungated = Mat4d::Identity();   // shadow filter (every ok registration)
  bool filter_initialized = false;                // false: fused_pose is the GNSS fix
  RegistrationStatus registration_status = RegistrationStatus::kInvalidInput;
  bool registration_attempted = false;
  double fitness = 0.0;
  double inlier_rmse = 0.0;
  bool registration_fused = false;          // passed the gate (causal) and the EKF's NIS gate
  bool basin_audited = false;               // the tracked basin was audited this frame
  // Global search diagnostics (this frame's exhaustive search, if one ran).
  bool searched = false;
  bool search_heading_used = false;         // the GNSS course limited the search's yaw
  double search_best_tight = 0.0;           // best basin's fitness at the tight threshold
  double search_runner_up_tight = 0.0;      // best other basin's (0: none)
  double search_best_conflicts = -1.0;      // their ray conflict ratios (pose_search.hpp)
  double search_runner_up_conflicts = -1.0;
  Mat4d search_best_pose = Mat4d::Identity();
  Mat4d search_runner_up_pose = Mat4d::Identity();
  // Stereo registration (tracking only, LiDAR + stereo configuration).
  bool stereo_attempted = false;
  bool stereo_fused = false;
  Mat4d stereo_pose = Mat4d::Identity();
  double stereo_fitness = 0.0;
  std::uint32_t stereo_points = 0;          // after the depth-noise filter and downsampling
  // Fixed-lag gate decision that became available at this frame (for frame decided_frame).
  bool gate_decided = false;
  std::uint32_t gate_decided_frame = 0;
  bool gate_decided_valid = false;
  double sigma_x = 0.0, sigma_y = 0.0, sigma_z = 0.0, sigma_yaw = 0.0;  // fused 1-sigma
  bool localized = false;                   // fused sigma_xy below the localized threshold
  // Earlier frames whose output the filter's start at this frame revised (Localizer::backfill()).
  std::uint32_t revised_frames = 0;
};

struct LocalizerCounters {
  std::uint32_t frames = 0;
  std::uint32_t global_searches = 0;
  std::uint32_t global_accepted = 0;
  std::uint32_t tracking_registrations = 0;
  std::uint32_t registrations_ok = 0;
  std::uint32_t registrations_fused = 0;       // main EKF
  std::uint32_t registrations_gate_rejected = 0;
  std::uint32_t map_rebuilds = 0;
  std::uint32_t gnss_received = 0;
  std::uint32_t gnss_invalid = 0;
  std::uint32_t scan_points_dropped = 0;       // non-finite, out of range or over capacity
  std::uint32_t odometry_failures = 0;
  std::uint32_t pending_overflow = 0;          // fixed-lag registrations that found no slot
  std::uint32_t filter_resets = 0;             // filter restarted at a registration
  std::uint32_t global_confirmed = 0;          // global solutions confirmed by a second search
  std::uint32_t global_inconsistent = 0;       // second search disagreed: candidate replaced
  std::uint32_t track_losses = 0;              // filter dropped (GNSS divergence or basin audit)
  std::uint32_t basin_audits = 0;              // exhaustive checks of the tracked basin
  std::uint32_t basin_switches = 0;            // audits that found a clearly better pose
  std::uint32_t ambiguities_resolved = 0;      // ambiguous searches decided by the GNSS track
  std::uint32_t gnss_headings = 0;             // fixes whose course over ground was usable
  std::uint32_t heading_searches = 0;          // global searches with the course as yaw window
  std::uint32_t stereo_registrations = 0;
  std::uint32_t stereo_fused = 0;              // passed the stereo gate and the EKF's NIS gate
  std::uint32_t road_height_outputs = 0;       // pre-filter outputs at the map's road height
};

class Localizer {
 public:
  Localizer() = default;
  Localizer(const Localizer&) = delete;
  Localizer& operator=(const Localizer&) = delete;

  // Resets everything; origin is the local ENU frame the map and the outputs live in.
  void configure(const LocalizerParams& params, const GeodeticOrigin& origin);

  void on_vehicle(const VehicleInput& input);
  void on_gnss(const GnssInput& input);
  MapInsertResult on_map_cloud(const MapCloudInput& input);
  // Processes one ego frame; the returned reference stays valid until the next call.
  const LocalizerFrameOutput& on_ego_scan(const EgoScanInput& input);

  // Optional observer of the stage boundaries inside on_ego_scan (host timing / profiling);
  // survives configure().
  void set_stage_probe(const StageProbe& probe) { probe_ = probe; }

  const LocalizerParams& params() const { return params_; }
  const Ekf& ekf() const { return ekf_; }
  // A second filter fed with every successful registration (no validity gate), for the paper's
  // "Fused" column; it never steers the registration.
  const Ekf& ekf_ungated() const { return ekf_all_; }
  const MapFusion& map() const { return map_; }
  const LocalizerCounters& counters() const { return counters_; }
  std::span<const Vec3f> map_points() const { return map_targets_[map_active_].points.span(); }
  // The last config::kBackfillFrames outputs, start-up frames revised once the filter starts.
  const TrajectoryBackfill& backfill() const { return backfill_; }

 private:
  struct PendingRegistration {
    std::uint32_t frame = 0;       // localizer frame index
    std::uint64_t gate_index = 0;  // push index in the fixed-lag gate
    double t = 0.0;
    Mat4d pose = Mat4d::Identity();
    Mat4d odom = Mat4d::Identity();  // odometry pose at that frame: carries a late restart to now
    Eigen::Matrix<double, 4, 4> covariance = Eigen::Matrix<double, 4, 4>::Identity();
    bool ok = false;
  };
  static constexpr std::size_t kPendingCapacity = config::kGateMaxWindow;

  void refresh_map(double t);
  bool map_build_step(double t);                 // false: nothing (more) to do this period
  void prepare_scan(const EgoScanInput& input);  // filter + deskew into scan_deskewed_
  IcpTarget map_target() const;                  // the reference map as an ICP target
  void run_odometry(const EgoScanInput& input);
  void register_scan(double t);
  void prepare_stereo(const StereoInput& stereo);  // disparity -> body-frame cloud, downsampled
  void register_stereo(double t);
  bool global_search(double t, RegistrationResult& result);
  bool confirm_global(const Mat4d& pose, bool output);  // true: agrees with the candidate
  void push_track_sample();
  // Mean horizontal distance between the GNSS fixes of the recent frames and the track a pose
  // hypothesis of this frame implies through the odometry; false when too few fixes.
  bool track_gnss_distance(const Mat4d& pose, double& mean_distance) const;
  void update_gnss_heading(const GnssInput& in);
  // The course over ground carried to time t by the yaw rate; false when none is usable.
  bool gnss_heading_at(double t, double& yaw) const;
  void lose_track();
  bool audit_basin(const RegistrationResult& tracked);  // false: tracking is in a wrong basin
  void fuse_gated(double t, const RegistrationResult& result, bool attempted_ok);
  void fuse_registration(Ekf& ekf, const PendingRegistration& reg, double now, bool& fused);
  void initialize_filters(double t, const Mat4d& pose);
  void restart_filter(Ekf& ekf, double t, const Mat4d& pose);
  void fill_output(double t);

  LocalizerParams params_{};
  StageProbe probe_{};
  GeodeticOrigin origin_{};
  LocalizerCounters counters_{};
  LocalizerFrameOutput output_{};
  TrajectoryBackfill backfill_{};

  // Fusion.
  Ekf ekf_{};
  Ekf ekf_all_{};
  FixedLagValidityGate fixed_lag_gate_{};
  CausalValidityGate causal_gate_{};
  PendingRegistration pending_[kPendingCapacity];
  std::uint32_t frame_ = 0;
  std::uint64_t gate_pushes_ = 0;
  std::uint32_t failed_frames_ = 0;
  std::uint32_t nis_rejections_ = 0;          // consecutive NIS rejections (main filter)
  std::uint32_t nis_rejections_ungated_ = 0;
  std::uint32_t frames_since_global_ = 0;
  struct GlobalCandidate {  // an accepted but unconfirmed global solution
    bool valid = false;
    std::uint32_t frame = 0;
    Mat4d pose = Mat4d::Identity();  // world_T_body
    Mat4d odom = Mat4d::Identity();  // odom_T_body at that frame
    bool output = false;             // unambiguous: a better estimate than the GNSS fix
  };
  struct TrackSample {               // per frame: odometry and latest GNSS position (2-D)
    double odom_x = 0.0, odom_y = 0.0, gnss_x = 0.0, gnss_y = 0.0;
    bool gnss = false;
  };
  static constexpr std::size_t kTrackFrames = 32;
  TrackSample track_[kTrackFrames];
  std::uint32_t track_count_ = 0;    // consecutive samples pushed (reset by odometry failures)
  GlobalCandidate candidate_{};
  Mat4d odom_T_body_ = Mat4d::Identity();  // this frame's odometry pose
  std::uint32_t gnss_divergent_fixes_ = 0;
  std::uint32_t frames_since_audit_ = 0;
  bool have_gnss_ = false;
  Vec3d last_gnss_enu_ = Vec3d::Zero();
  double last_gnss_sigma_ = 10.0;
  bool have_heading_ = false;      // a usable GNSS course over ground (ENU yaw)
  double heading_yaw_ = 0.0;       // [rad]
  double heading_t_ = 0.0;         // [s]
  double last_frame_t_ = 0.0;
  bool have_frame_ = false;
  double last_speed_ = 0.0;        // [m/s] latest wheel speed (filter initialization)
  double last_yaw_rate_ = 0.0;     // [rad/s]
  bool have_vehicle_ = false;
  bool have_vehicle_delta_ = false;
  Mat4d vehicle_delta_lidar_ = Mat4d::Identity();  // this frame's sensor motion from the signals
  Mat4d body_T_lidar_ = Mat4d::Identity();

  // Odometry (drifting, in its own frame).
  LidarOdometry odometry_{};

  // Reference map and its registration products.
  MapFusion map_{};
  // The registration target, double-buffered: registration reads map_targets_[map_active_]
  // while the next one is built over several periods (refresh_map).
  struct MapTarget {
    FixedVector<Vec3f, config::kMaxMapPoints> points;
    Vec3f normals[config::kMaxMapPoints];
    KdTreeStorage<Vec3f, config::kMaxMapPoints> tree;
  };
  enum class MapBuildPhase : std::uint8_t { kIdle, kTree, kNormals };
  static constexpr std::uint32_t kMapBuildSteps = 3;  // extract, tree, normals: one rebuild
  MapTarget map_targets_[2];
  std::uint32_t map_active_ = 0;
  MapBuildPhase map_phase_ = MapBuildPhase::kIdle;
  std::size_t map_normals_done_ = 0;
  bool map_tree_started_ = false;
  KdBuildResult map_tree_result_{};
  std::uint64_t map_build_revision_ = 0;
  std::uint64_t map_revision_ = ~0ull;
  double map_built_t_ = -1e300;
  bool map_ready_ = false;

  // Scan buffers.
  ScanIngest ingest_{};                                          // voxelised, deskewed sweep
  FixedVector<Vec3f, config::kMaxDownsampledPoints> scan_down_;  // ... in the body frame
  FixedVector<Vec3f, config::kMaxDownsampledPoints> tracking_scan_;  // tracking ICP's subsample
  // Each scan point's map match of the last ICP iteration seeds its next search (same matches,
  // fewer k-d tree nodes).
  std::uint32_t icp_hints_[config::kMaxDownsampledPoints];
  FixedVector<Vec3f, config::kMaxSearchPoints> search_scan_;  // pose search's subsample
  VoxelDownsampleStorage<config::kVoxelHashSlots, config::kMaxDownsampledPoints> voxel_;
  FixedVector<Vec3f, config::kMaxMapPoints> map_crop_;
  Vec3f stereo_points_[config::kMaxStereoPoints];
  float stereo_sigma_[config::kMaxStereoPoints];
  FixedVector<Vec3f, config::kMaxDownsampledPoints> stereo_down_;
  double stereo_mean_sigma_ = 0.0;  // [m] mean depth sigma of this frame's stereo points
  CausalValidityGate stereo_gate_{};
  RegistrationWorkspace global_workspace_;
};

}  // namespace v2xloc
