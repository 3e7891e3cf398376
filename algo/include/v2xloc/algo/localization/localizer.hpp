// The localizer: one ego frame through every stage (paper Fig. 1), each stage a component with
// its own state (KISS-ICP's RegisterFrame over stage objects, PX4 EKF2's one owner of the filter):
//   ImuIntake           IMU samples checked, counted, gyro z averaged for the filter and the deskew
//   ScanPreparation     range filter, deskew (wheel speed + gyro or CAN yaw rate), registration scan, stereo
//   LidarOdometry       relative motion, predicted from the same signals
//   ReferenceMap        infra/agent clouds fused (map_fusion) -> target: points, k-d tree, normals
//   TrackingRegistration ICP from the filter's prediction, basin audit, stereo ICP
//   StartupSearch       GNSS-seeded exhaustive search, confirmation by a second search
//   PoseFilter          validity gates -> EKF (wheel speed / yaw rate, gyro, GNSS, odometry, registrations)
//   FrameOutput         the filter's pose, or before its start the GNSS fix on the road surface
// Lost track (GNSS divergence, basin audit) -> start-up search again.
// Inputs arrive through on_*() calls in time order per source; the caller decides the event
// order, and the same order gives the same bits (offline evaluator and firmware share it).
// All storage is inside the object (hundreds of MB on the host profile): make it static.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/geodesy.hpp"
#include "v2xloc/algo/localization/ekf.hpp"
#include "v2xloc/algo/localization/frame_output.hpp"
#include "v2xloc/algo/localization/imu_intake.hpp"
#include "v2xloc/algo/localization/gnss_course.hpp"
#include "v2xloc/algo/localization/ground_attitude.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"
#include "v2xloc/algo/localization/map_fusion.hpp"
#include "v2xloc/algo/localization/odometry.hpp"
#include "v2xloc/algo/localization/pose_filter.hpp"
#include "v2xloc/algo/localization/reference_map.hpp"
#include "v2xloc/algo/localization/scan_preparation.hpp"
#include "v2xloc/algo/localization/stage_probe.hpp"
#include "v2xloc/algo/localization/startup_search.hpp"
#include "v2xloc/algo/localization/tracking.hpp"
#include "v2xloc/algo/localization/trajectory_backfill.hpp"

namespace v2xloc {

class Localizer {
 public:
  Localizer() = default;
  Localizer(const Localizer&) = delete;
  Localizer& operator=(const Localizer&) = delete;

  // Resets everything; origin is the local ENU frame the map and the outputs live in.
  void configure(const LocalizerParams& params, const GeodeticOrigin& origin);

  void on_vehicle(const VehicleInput& input);
  void on_gnss(const GnssInput& input);
  void on_imu(const ImuInput& input);
  MapInsertResult on_map_cloud(const MapCloudInput& input);
  // Provisioning, after configure(): infrastructure unit source_id's surveyed background (cells in
  // the caller's storage, read for as long as the localizer runs); its clouds are then checked
  // against it (map_fusion.hpp). False: not a valid background, or no background slot left.
  bool set_background(std::uint32_t source_id, const SurveyedBackground& background) {
    return map_.set_background(source_id, background);
  }
  // False when on_map_cloud would not fuse a cloud of this source and time (kPaced: the source's
  // stored cloud is recent, reference_map.hpp); lets the caller skip the share's signature check.
  bool wants_map_cloud(std::uint32_t source_id, double t) const { return map_.wants(source_id, t); }
  // False when on_map_cloud would refuse this infrastructure cloud as off its unit's surveyed
  // background (map_fusion.hpp); nothing is inserted or counted. Lets the caller skip its signature check.
  bool map_cloud_fits_background(std::uint32_t source_id, const Mat4d& world_T_sensor,
                                 std::span<const Vec3f> points) const {
    return map_.fusion().fits_background(source_id, world_T_sensor, points);
  }
  // A reference map is built and in use (false before the first one, or after every source expired).
  bool has_map() const { return map_.ready(); }
  // How many map clouds the next period should fuse at most (the caller's share schedule applies
  // its own cap too): map_clouds_per_period_tracking while tracking; none until the first
  // acquisition is over once a map exists (defer_map_clouds_first_search); else no limit.
  std::uint32_t map_clouds_per_period() const {
    if (params_.defer_map_clouds_first_search && map_.ready() && startup_.first_acquisition_pending(frame_)) return 0;
    return filter_.can_track() && params_.map_clouds_per_period_tracking > 0 ? params_.map_clouds_per_period_tracking
                                                                             : ~std::uint32_t{0};
  }
  // Work the caller did in this period outside the localizer (the firmware's share hashing and
  // signature checks), in estimated instructions: the deferrable stages (map rebuild, basin audit,
  // search slices) take only what the period budget has left after it. Before on_ego_scan.
  void add_period_work(double instructions) {
    if (instructions > 0.0 && instructions < 1e12) work_.add(instructions);  // also refuses NaN
  }
  // Processes one ego frame; the returned reference stays valid until the next call.
  const LocalizerFrameOutput& on_ego_scan(const EgoScanInput& input);

  // Optional observer of the stage boundaries inside on_ego_scan (host timing / profiling);
  // survives configure().
  void set_stage_probe(const StageProbe& probe) { probe_ = probe; }

  const LocalizerParams& params() const { return params_; }
  const Ekf& ekf() const { return filter_.ekf(); }
  const MapFusion& map() const { return map_.fusion(); }
  const LocalizerCounters& counters() const { return counters_; }
  std::span<const Vec3f> map_points() const { return map_.points(); }
  // The last config::kBackfillFrames outputs, start-up frames revised once the filter starts.
  const TrajectoryBackfill& backfill() const { return backfill_; }

 private:
  // The stages of on_ego_scan, in order.
  VehicleMotion deskew_motion(double t);
  void run_odometry(const EgoScanInput& in);
  void register_frame(double t, const Mat4d& body_T_lidar);
  RegistrationResult track(double t, const Mat4d& body_T_lidar, bool& withheld);
  StartupOutcome search(double t, const Mat4d& body_T_lidar);
  void predict_only(double t);
  void fuse(double t, const RegistrationResult& result, bool attempted_ok, bool withheld, bool no_data = false);
  void fill_output(double t);
  void push_backfill();

  void note_input_time(double t) {
    if (!have_input_t_ || t > latest_input_t_) latest_input_t_ = t;
    have_input_t_ = true;
  }
  void report_registration(const RegistrationResult& result);
  void lose_track();
  std::span<std::uint32_t> icp_hints() { return {icp_hints_, config::kMaxDownsampledPoints}; }

  LocalizerParams params_{};
  StageProbe probe_{};
  GeodeticOrigin origin_{};
  LocalizerCounters counters_{};
  LocalizerFrameOutput output_{};
  TrajectoryBackfill backfill_{};

  // Inputs as they arrived.
  std::uint32_t frame_ = 0;
  double last_frame_t_ = 0.0;
  bool have_frame_ = false;
  double last_odometry_t_ = 0.0;     // [s] the last sweep with points (the odometry's previous frame)
  bool have_odometry_frame_ = false;
  VehicleMotion vehicle_{};
  GnssFix gnss_{};
  GnssCourse course_{};
  Pose3d odom_T_body_ = Pose3d::Identity();  // this frame's odometry pose
  bool have_input_t_ = false;                // latest stamp of the vehicle, GNSS and scan inputs
  double latest_input_t_ = 0.0;              // (the IMU's time-jump check)
  ImuIntake imu_{};

  // The stages.
  ScanPreparation scan_{};
  LidarOdometry odometry_{};                 // drifting, in its own frame
  ReferenceMap map_{};
  PeriodWork work_{};                    // this period's estimated instructions (period_work.hpp)
  double tracking_forecast_ = 0.0;       // [instructions] the last tracked period's registration
  std::uint32_t rebuild_deferred_ = 0;   // rebuild steps deferred in a row
  PoseFilter filter_{};
  GroundAttitude attitude_{};  // roll and pitch for the tracking guess
  StartupSearch startup_{};
  TrackingRegistration tracking_{};
  FrameOutput frame_output_{};
  // ICP scratch shared by the stages: each scan point's map match of the last ICP iteration
  // seeds its next search (same matches, fewer k-d tree nodes); reset by every ICP call.
  std::uint32_t icp_hints_[config::kMaxDownsampledPoints];
  // The pose search jobs' scratch (lattice table, climb points), shared by the start-up search
  // and the basin audit: one runs at a time, and a job refills a table it finds another's in.
  PoseSearchScratch search_scratch_;
};

}  // namespace v2xloc
