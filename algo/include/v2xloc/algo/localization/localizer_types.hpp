// The localizer's inputs, its per-frame output and its counters (localizer.hpp), and the two
// pieces of input state its stages share: the latest vehicle motion and the latest GNSS fix.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/localization/pose_types.hpp"
#include "v2xloc/algo/localization/stereo_cloud.hpp"
#include "v2xloc/algo/registration/registration_result.hpp"

namespace v2xloc {

struct VehicleInput {
  double t = 0.0;                // [s] measurement time
  double wheel_speed = 0.0;      // [m/s]
  double yaw_rate = 0.0;         // [rad/s]
};

// One inertial sample (hal/HID_IMU_REPORT.md), its sensor time already on the inputs' clock.
struct ImuInput {
  double t = 0.0;                  // [s] sample time
  double gyro[3] = {0, 0, 0};      // [rad/s] angular rate, body frame (x forward, y left, z up)
  double accel[3] = {0, 0, 0};     // [m/s^2] specific force, body frame
  bool saturated = false;          // the sensor flagged an axis at its range limit
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
  Pose3d world_T_sensor = Pose3d::Identity();
  std::span<const Vec3f> points{};  // sensor frame
  // The caller scored exactly these points at this pose on the source's surveyed background
  // (Localizer::map_cloud_fits_background) and they fit: map fusion takes that verdict instead of
  // scoring them again (2.7 M instructions on a real roadside cloud). False: map fusion scores.
  bool background_fits = false;
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
  Pose3d body_T_lidar = Pose3d::Identity();
  StereoInput stereo{};          // used when LocalizerParams::use_stereo and disparity is given
};

enum class LocalizationMode : std::uint8_t {
  kUninitialized,  // no GNSS / no map yet
  kGlobalSearch,   // start-up pose search within the GNSS uncertainty region
  kTracking,       // ICP from the EKF prediction
};

struct LocalizerFrameOutput {
  std::uint32_t frame = 0;
  double t = 0.0;
  LocalizationMode mode = LocalizationMode::kUninitialized;
  // Odometry in its own frame (odom_T_body; the odom frame is the LiDAR frame of the first
  // scan), registration and fused poses (world_T_body).
  Pose3d odometry_pose = Pose3d::Identity();
  bool odometry_ok = false;
  Pose3d registration_pose = Pose3d::Identity();
  Pose3d fused_pose = Pose3d::Identity();           // main filter (gated registrations)
  Pose3d fused_pose_ungated = Pose3d::Identity();   // shadow filter (every ok registration)
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
  Pose3d search_best_pose = Pose3d::Identity();
  Pose3d search_runner_up_pose = Pose3d::Identity();
  // Stereo registration (tracking only, LiDAR + stereo configuration).
  bool stereo_attempted = false;
  bool stereo_fused = false;
  Pose3d stereo_pose = Pose3d::Identity();
  double stereo_fitness = 0.0;
  std::uint32_t stereo_points = 0;          // after the depth-noise filter and downsampling
  // Fixed-lag gate decision that became available at this frame (for frame decided_frame).
  bool gate_decided = false;
  std::uint32_t gate_decided_frame = 0;
  bool gate_decided_valid = false;
  double sigma_x = 0.0, sigma_y = 0.0, sigma_z = 0.0, sigma_yaw = 0.0;  // fused 1-sigma
  bool localized = false;                   // fused sigma_xy below the localized threshold
  // The sweep had no points to register (a covered or silent LiDAR): the pose is the filter's
  // prediction, and the frame counts neither as a registration nor as a failed one.
  bool no_scan_data = false;
  // Earlier frames whose output the filter's start at this frame revised (Localizer::backfill()).
  std::uint32_t revised_frames = 0;
};

struct LocalizerCounters {
  std::uint32_t frames = 0;
  std::uint32_t global_searches = 0;
  std::uint32_t global_searches_dropped = 0;   // search jobs dropped: odometry broke, or too slow
  std::uint32_t global_accepted = 0;
  std::uint32_t tracking_registrations = 0;
  std::uint32_t registrations_ok = 0;
  std::uint32_t registrations_fused = 0;       // main EKF
  std::uint32_t registrations_gate_rejected = 0;
  std::uint32_t map_rebuilds = 0;
  std::uint32_t map_clouds_paced = 0;          // clouds not fused: their source's last is recent (map.cloud_interval)
  std::uint32_t map_normals_computed = 0;      // map normals computed on first use
  std::uint32_t map_normals_refused = 0;       // asked past the per-period cap: pair skipped
  std::uint32_t gnss_received = 0;
  std::uint32_t gnss_invalid = 0;
  std::uint32_t imu_received = 0;
  std::uint32_t imu_invalid = 0;               // refused: non-finite or saturated
  std::uint32_t imu_out_of_order = 0;          // refused: not after the previous sample
  std::uint32_t imu_time_jumps = 0;            // refused: ahead of the other inputs by more than filter.imu.max_lead
  std::uint32_t imu_gaps = 0;                  // dropouts: silences longer than filter.imu.max_gap
  std::uint32_t imu_stuck_axes = 0;            // stuck episodes, any of the six axes (gyro z's are not fused)
  std::uint32_t imu_gyro_rejected = 0;         // gyro measurements the filter's NIS gate refused
  std::uint32_t imu_inconsistent = 0;          // gyro against the CAN yaw rate: a bias step detected
  std::uint32_t imu_bias_resets = 0;           // gyro bias variance restarts (rejections or inconsistency)
  std::uint32_t imu_deskews = 0;               // sweeps deskewed at the gyro's yaw rate (filter.imu.deskew_window)
  std::uint32_t scan_points_dropped = 0;       // non-finite, out of range or over capacity
  std::uint32_t scans_coarsened = 0;           // sweeps over the ingest capacity, read again with a coarser voxel
  std::uint32_t odometry_failures = 0;
  std::uint32_t frames_without_scan_data = 0;  // sweeps with no points to register: predicted only
  std::uint32_t pending_overflow = 0;          // fixed-lag registrations that found no slot
  std::uint32_t filter_resets = 0;             // filter restarted at a registration
  std::uint32_t reacquisitions_refused = 0;    // search answers outside the running filter's belief
  std::uint32_t global_confirmed = 0;          // global solutions confirmed by a second search
  std::uint32_t global_inconsistent = 0;       // second search disagreed: candidate replaced
  std::uint32_t global_final_icp_paused = 0;   // periods a search's final ICP ran out of room in (it resumes)
  std::uint32_t global_unconstrained = 0;      // solutions refused: free along one horizontal direction
  std::uint32_t track_losses = 0;              // filter dropped (GNSS divergence or basin audit)
  std::uint32_t basin_audits = 0;              // exhaustive checks of the tracked basin
  std::uint32_t basin_switches = 0;            // audits that found a clearly better pose
  std::uint32_t ambiguities_resolved = 0;      // ambiguous searches decided by the GNSS track
  std::uint32_t gnss_headings = 0;             // fixes whose course over ground was usable
  std::uint32_t heading_searches = 0;          // global searches with the course as yaw window
  std::uint32_t stereo_registrations = 0;
  std::uint32_t stereo_fused = 0;              // passed the stereo gate and the EKF's NIS gate
  std::uint32_t road_height_outputs = 0;       // pre-filter outputs at the map's road height
  // Work counts behind the period budget (period_work.hpp):
  std::uint64_t odometry_queries = 0;          // odometry source points x iterations
  std::uint64_t tracking_queries = 0;          // tracking ICP points x nearest-neighbour passes
  std::uint64_t audit_work = 0;                // basin-audit search work units
  std::uint64_t global_search_work = 0;        // start-up / lost-track search work units
  std::uint32_t odometry_query_capped = 0;     // odometry frames whose iterations max_queries ended
  std::uint32_t odometry_frames_thinned = 0;   // odometry frames thinned to max_fine_points
  std::uint32_t tracking_work_capped = 0;      // tracking ICPs that ran out of work (tracking.icp.max_work)
  std::uint32_t rebuild_steps_deferred = 0;    // map rebuild steps that waited for a period with room
  std::uint32_t rival_checks_deferred = 0;     // contested frames the period's room held no rival decision in
  std::uint32_t audit_decisions_deferred = 0;  // tracked frames an audit nomination waited for its decision
  std::uint32_t audit_periods_starved = 0;     // running audits that got no work in a period
};

// The latest wheel speed and yaw rate (deskew, odometry prediction, filter (re)starts).
struct VehicleMotion {
  bool valid = false;
  double speed = 0.0;     // [m/s]
  double yaw_rate = 0.0;  // [rad/s]
};

// The latest valid GNSS fix in local ENU.
struct GnssFix {
  bool valid = false;
  Vec3d enu = Vec3d::Zero();  // [m]
  double sigma = 10.0;        // [m] reported 1-sigma horizontal accuracy
};

}  // namespace v2xloc
