// Every tuning value of the localizer: one line each, unit and rule, grouped by the stage component
// that reads it (each component is configured with its own group; a value another stage needs is
// passed to it explicitly, named where the group is). Defaults are what v2xloc-eval runs; its
// ablations flip the switches. Why a value is what it is, measured on which recording:
// algo/TUNING.md.
#pragma once

#include <cstdint>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/ekf.hpp"
#include "v2xloc/algo/localization/map_fusion.hpp"
#include "v2xloc/algo/localization/odometry.hpp"
#include "v2xloc/algo/localization/period_work.hpp"
#include "v2xloc/algo/localization/stereo_cloud.hpp"
#include "v2xloc/algo/localization/validity_gate.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {

enum class GateMode : std::uint8_t {
  kFixedLag,  // paper's centred window; a registration is fused w/2 frames late, at its stamp
  kCausal,    // past window only; fused immediately
  kOff,       // every successful registration is fused (the paper's "Fused" column)
};

// ScanPreparation (scan_preparation.hpp); also given LocalizerParams::use_vehicle_signals.
struct ScanPreparationParams {
  double frame_period = 0.1;          // [s] LiDAR sweep period: deskew span and vehicle-signal delta
  float min_range = 3.0f;             // [m] returns closer than this are the ego body: dropped
  float max_range = 80.0f;            // [m] returns farther than this are sparse and noisy: dropped
  float registration_voxel = 0.5f;    // [m] ingest voxel (LiDAR frame): odometry's 0.5 v frame and the registration scan
  std::uint32_t tracking_points = 1500;  // [points] even scan subsample the tracking ICP registers (0: all; TUNING.md)
  // [points] even scan subsample the pose search scores and refines on (<= config::kMaxSearchPoints)
  std::uint32_t search_points = 1024;
  StereoParams stereo = default_stereo();  // disparity -> cloud (stereo_cloud.hpp)
  float stereo_voxel = 0.3f;          // [m] stereo cloud downsampling

  static StereoParams default_stereo() {
    StereoParams p;
    p.stride = 4;                   // every 4th pixel in u and v: ~1/16 of the image
    p.min_disparity = 2.0;          // [px]
    p.disparity_sigma = 0.5;        // [px] overridden by the calibration's value when known
    p.max_depth_sigma = 0.3;        // [m] ~15-20 m range for the ego rig
    return p;
  }
};

// ReferenceMap (reference_map.hpp); also given tracking.icp's gate (the vicinity bitmap's reach).
struct ReferenceMapParams {
  MapFusionParams fusion{};           // fused infrastructure + agent clouds (map_fusion.hpp)
  // [s] rebuild map points / tree / vicinity bitmap at most this often (host 2, EMBEDDED 1; TUNING.md)
  double refresh_period = config::kEmbeddedProfile ? 1.0 : 2.0;
  double refresh_quiet_wait = 0.5;    // [s] a due rebuild waits this long at most for a period without new clouds
  // [s] a source's cloud is fused at most this often, just under refresh_period (0: every cloud)
  double cloud_interval = config::kEmbeddedProfile ? 0.9 : 1.9;
  float normal_radius = 0.6f;         // [m] normal estimation radius on the map (3 map voxels)
  std::uint32_t min_points = 100;     // [points] a map with fewer is not registered against
  // [normals/period] map normals computed on first ICP match (lazy_normals.hpp); past it a pair has none
  std::uint32_t normals_per_period = 8192;
  // [point visits/period] the next map's k-d tree is built this much per period (0: at once)
  std::uint32_t tree_work_per_period = 125000;
  // [m] vicinity bitmap cell (grows to fit the map); ICP queries it proves empty skip the tree (0: off)
  float vicinity_cell = 0.5f;
};

// TrackingRegistration (tracking.hpp).
// A decision between the tracked basin and another on one frame's scan, within the period's
// remaining budget (basin_decision.hpp): a frame whose room cannot hold it waits (the candidate's
// ICP resumes next frame from the carried pose; the two fitness evaluations take an even subsample
// of at least min_points), and after max_deferred_frames frames without a decision one runs
// regardless.
struct BasinDecisionParams {
  std::uint32_t min_points = 1000;        // [points]
  std::uint32_t max_deferred_frames = 5;  // [frames]
};

// RivalBasin (rival_basin.hpp): a new track whose start-up searches saw another basin nearly as
// good is contested (its registrations neither fused nor valid) until the full scan decides.
struct RivalBasinParams {
  double contest_ratio = 0.6;    // [ratio] a distinct hypothesis' search tight fitness over the started basin's: contested
  double resolve_ratio = 1.3;    // [ratio] tracked full-scan tight fitness over the rival's: the track stands
  double switch_ratio = 1.15;    // [ratio] the rival's over the tracked: a basin switch (a search confirms it)
  std::uint32_t max_age_frames = 50;  // [frames] older start-up hypotheses are forgotten (odometry drift)
  BasinDecisionParams decision{};     // the check within the period's budget
};

struct TrackingParams {
  IcpParams icp = default_icp();      // tracking ICP: point-to-plane from the EKF prediction
  std::uint32_t stereo_min_points = 200;  // [points] fewer after downsampling: not registered
  IcpParams stereo_icp = default_icp();   // stereo ICP from the same prediction
  RivalBasinParams rival{};               // a contested start (TUNING.md, "Rival basin")

  static IcpParams default_icp() {
    IcpParams p;
    p.method = IcpMethod::kPointToPlane;  // [-] point-to-plane (map normals)
    p.max_correspondence_distance = 1.0;  // [m] tracking gate around the EKF prediction
    p.criteria.max_iterations = 20;       // [iterations] cap (one nearest-neighbour pass each)
    p.criteria.relative_fitness = 1e-3;   // [-] stop below this fitness change ... (TUNING.md)
    p.criteria.relative_rmse = 1e-3;      // [m] ... and below this RMSE change
    p.kernel.type = RobustKernelType::kTukey;  // [-] robust kernel
    p.kernel.scale = 0.3;                 // [m] Tukey scale: residuals beyond it weigh nothing
    // [work units] ~44 M instructions; past it kDidNotConverge, counted tracking_work_capped
    p.max_work = 400000;
    return p;
  }
};

// StartupSearch (startup_search.hpp); also given tracking.icp (the final ICP) and
// filter.ekf.gates.gnss_sigma_inflation (the region's GNSS sigma).
struct StartupSearchParams {
  PoseSearchParams search = default_search();  // GNSS-seeded exhaustive search (the basin audit's too)
  double gnss_gate_sigmas = 4.0;      // [sigma] region radius in inflated GNSS sigmas (+1 m)
  double min_region = 30.0;           // [m] region radius floor (canyon NLOS; TUNING.md)
  double max_region = 45.0;           // [m] region radius ceiling after searches that matched nothing
  double region_growth = 1.5;         // [ratio] region growth per such search; back to the floor on a match
  double min_fitness = 0.3;           // [0-1] a solution needs at least this ICP fitness
  // [0-0.5] a solution's final-ICP horizontal constraint at least this (0: off; off on EMBEDDED)
  double min_horizontal_constraint = config::kEmbeddedProfile ? 0.0 : 0.04;
  double max_ambiguity = 0.85;        // [0-1] runner-up / winner tight fitness above: ambiguous
  // [ratio] ray-conflict radius at least this x the map's measured point spacing (0: the fixed radius; TUNING.md)
  double conflict_radius_per_spacing = 0.45;
  std::uint32_t spacing_samples = 64; // [points] map points whose nearest-neighbour distance gives the spacing
  std::uint32_t retry_frames = 2;     // [frames] between two searches (bounded cost)
  std::uint32_t work_per_period = 800000;    // [work units/period] search slice ceiling (0: all at once)
  std::uint32_t min_work_per_period = 30000;  // [work units/period] search slice floor, budget or not
  std::uint32_t first_frames = 10;    // [frames] since the first search: the first acquisition at most
  // [work units/period] first-acquisition slice floor, budget or not (0: within the budget; TUNING.md)
  std::uint32_t first_work_per_period = 0;
  // [frames] a search job not finished within this is dropped (a bound for crowded periods: an
  // EMBEDDED first search takes 2-4 on the recordings, TUNING.md "EMBEDDED: the first acquisition")
  std::uint32_t max_frames = 40;
  std::uint32_t confirm_window = 10;  // [frames] a second search within this confirms (0: off)
  double confirm_distance = 0.5;      // [m] confirmation: horizontal disagreement allowed
  double confirm_yaw = 0.035;         // [rad] confirmation: heading disagreement allowed (2 deg)
  std::uint32_t track_frames = 30;    // [frames] GNSS track compared (<= kTrackFrames)
  std::uint32_t track_min_fixes = 10; // [fixes] needed in the track to decide
  double track_distance_ratio = 0.6;  // [ratio] winner's mean track distance < ratio * loser's
  double track_distance_margin = 5.0; // [m] ... and smaller by at least this
  double track_max_distance = 25.0;   // [m] a solution whose track is farther is wrong
  // An ambiguity the track leaves open goes to the pose whose ray conflict ratio (pose_search.hpp)
  // is lower, when the other's is at least conflict_ratio x it and conflict_margin above it
  // (5 of 128 rays; TUNING.md "Ambiguity and the map's negative evidence").
  double conflict_ratio = 2.0;        // [ratio]
  double conflict_margin = 0.04;      // [0-1]
  double heading_tolerance = 0.79;    // [rad] yaw window half-width around the GNSS course (45 deg)

  static PoseSearchParams default_search() {
    PoseSearchParams p;
    p.icp.method = IcpMethod::kPointToPlane;  // [-] coarse ICP: point-to-plane
    p.icp.max_correspondence_distance = 2.0;  // [m] coarse ICP gate: about half a grid cell's diagonal
    p.icp.criteria.max_iterations = 20;      // [iterations]
    p.icp.criteria.relative_fitness = 1e-3;  // [-] the coarse ICP only picks the basin
    p.icp.criteria.relative_rmse = 1e-3;     // [m]
    p.icp.kernel.type = RobustKernelType::kTukey;  // [-] robust kernel
    // [m] coarse ICP's Tukey scale = its gate (TUNING.md)
    p.icp.kernel.scale = 2.0;
    p.yaw_steps = 24;               // [headings] 15 deg apart; the coarse ICP pulls in +-7.5 deg
    p.step = 3.0;                   // [m] position grid spacing
    p.radius = 30.0;                // [m] = min_region (bounded work: ~8k hypotheses)
    p.score_points = 64;            // [points] scan points scored per hypothesis (the climb re-ranks on 256)
    p.refine_candidates = 5;        // [hypotheses] the best distinct ones refined by ICP
    p.climb_points = 256;           // [points] the kept hypotheses climb to their basins' bottoms (TUNING.md)
    p.refine_min_score_ratio = 0.8; // [0-1] and only those within 20 % of the best climbed score are refined
    // [points] candidates' ICPs on this many search points (host 256 = every 4th; EMBEDDED 384 of
    // its thinner 1,024: 3/8; TUNING.md)
    p.refine_points = config::kEmbeddedProfile ? 384u : 256u;
    // [work units] the power-up slice's coarse ICP of the best hypothesis (host: its 256-point ICP
    // whole, ~17 M instructions; EMBEDDED ~7 M of its ~42 M, beside the first map and clouds)
    p.power_up_coarse_work = config::kEmbeddedProfile ? 60000u : 150000u;
    p.score_distance = 2.0;         // [m] score hit radius: half the grid cell's diagonal (TUNING.md)
    p.max_conflicts = 0.12;         // [0-1] ray conflict ratio above which a pose is no candidate (TUNING.md)
    p.clear_margin = true;          // [switch] the fitness margin from the best pose whose rays pass (TUNING.md)
    p.fine_icp = TrackingParams::default_icp();  // [-] fine ICP: the tracking ICP's settings ...
    p.fine_icp.criteria.relative_fitness = 1e-5;  // [-] ... converged fully: candidates compare fitness
    p.fine_icp.criteria.relative_rmse = 1e-5;     // [m]
    return p;
  }
};

// BasinAudit (basin_audit.hpp, run by TrackingRegistration); also given startup.search (its
// lattice, radius and candidates replaced below) and tracking.icp (the switch's full-scan ICP).
struct BasinAuditParams {
  // [frames] from one audit's end to the next one's start while tracking (0: off)
  std::uint32_t period_frames = 30;
  // [frames] a new track's first audit starts after this many, with all the period's room left
  std::uint32_t first_frames = 1;
  double radius = 8.0;                // [m] search disc around the tracked pose
  // [work units/period] audit slice per tracked frame, at most the room left (0: whole search at once)
  std::uint32_t work_per_period = 90000;
  // [work units/period] ... in a period that fused a map cloud (0: the audit pauses there)
  std::uint32_t work_per_busy_period = 45000;
  std::uint32_t max_frames = 60;      // [frames] an audit not finished within this is dropped (pauses count)
  std::uint32_t refine_candidates = 5;  // [hypotheses] the audit refines by ICP (<= kPoseSearchRefine; TUNING.md)
  double switch_ratio = 1.15;         // [ratio] audit pose's tight fitness over tracked: switch
  double full_switch_ratio = 1.15;    // [ratio] ... and again on the full scan after ICP: switch
  BasinDecisionParams decision{};     // that full-scan decision within the period's budget
};

// GnssCourse (gnss_course.hpp).
struct GnssCourseParams {
  bool enabled = true;                // GNSS course over ground as start-up yaw window and pre-filter heading
  double min_speed = 3.0;             // [m/s] Doppler and wheel speed both above this
  double max_sigma = 0.17;            // [rad] course sigma atan(speed_acc / speed) at most this
  double max_age = 1.0;               // [s] a course older than this is not used
};

// The IMU's samples on their way into the filter (imu_intake.hpp, PoseFilter::on_gyro); the
// sensor's own figures (angle random walk, bias random walk) are filter.ekf.noise's gyro_*.
struct ImuParams {
  double fuse_period = 0.01;          // [s] gyro z samples averaged into one filter measurement (PX4 EKF2's 10 ms)
  double max_gap = 0.05;              // [s] a longer silence is a dropout: the stream restarts, the CAN yaw rate takes over
  double max_lead = 0.5;              // [s] a sample this far ahead of the latest other input is a time jump: refused
  // [s] the gyro stands in for the CAN yaw rate this long after its last fused measurement (the
  // firmware hands a period's IMU samples on when the period closes: 0.1 s late at most)
  double live_window = 0.25;
  // [samples] identical values in a row on an axis: stuck (a live MEMS axis's noise spans many LSBs)
  std::uint32_t stuck_samples = 50;
  std::uint32_t reset_after_rejections = 20;  // [measurements] gyro NIS rejections in a row -> bias variance reset
  double bias_reset_sigma = 0.02;     // [rad/s] gyro bias sigma after that reset (a ~1 deg/s step)
  // [s] time constant of the running mean of (gyro - CAN yaw rate - their bias difference) ...
  double consistency_window = 1.0;
  double consistency_limit = 0.005;   // [rad/s] ... beyond which the gyro bias stepped: variance reset (TUNING.md)
  // [s] the sweep's deskew turns at the gyro's mean over this much before the frame stamp, carried
  // along its trend to the sweep's middle, less the filter's bias, instead of the latest CAN yaw
  // rate (0: the CAN yaw rate; TUNING.md) ...
  double deskew_window = 0.02;
  double deskew_trend = 0.08;         // [s] ... the trend: the change from the same mean this much earlier
  // [switch] fuse the CAN yaw rate beside the gyro (off: the wheel speed alone while the gyro is live; TUNING.md)
  bool can_yaw_rate_with_gyro = true;
};

// PoseFilter (pose_filter.hpp); also given LocalizerParams::use_vehicle_signals.
struct PoseFilterParams {
  GateMode gate_mode = GateMode::kFixedLag;  // which validity gate feeds the EKF
  ValidityGateParams gate = default_gate();  // paper's envelope + absolute floors (TUNING.md)
  EkfParams ekf{};                           // filter noise and NIS gates (ekf.hpp)
  RegistrationCovarianceParams registration_covariance{};  // ICP information -> pose covariance
  std::uint32_t reset_after_rejections = 3;  // [registrations] NIS-rejected in a row -> restart
  // [-] 1-sigma of the carried body pitch as the road's grade (ground_attitude.hpp): a car's
  // suspension pitches it by a few tenths of a degree under braking and acceleration (0.3 deg ~ 0.5 %).
  double road_grade_sigma = 0.005;
  // [m, m, m, rad, m/s, rad/s, rad/s, -, rad/s, -, -, rad] 1-sigma of each state (ekf_index order) at a
  // (re)start; the gyro bias's (0.01 rad/s: the MEMS class's turn-on zero-rate offset) and scale
  // error's (0.5 %: the class's sensitivity error) when no earlier estimate exists; the road
  // grade's 5 % (a steep city street); the odometry anchor's (states 11-13) are replaced at the
  // first odometry frame.
  double restart_sigmas[kEkfStateSize] = {0.1, 0.1, 0.1, 0.01, 0.5, 0.05, 0.005, 0.02, 0.01, 0.005, 0.05, 0.01, 0.1, 0.1};
  ImuParams imu{};                           // the IMU's intake and its use (above)
  double tracking_max_sigma_xy = 0.5;        // [m] EKF position sigma above which the start-up search runs
  std::uint32_t max_failed_frames = 10;      // [frames] consecutive unfused registrations -> start-up search
  // A search answer that would restart a filter still running (started by max_failed_frames, the
  // EKF initialized) must lie inside the filter's belief: position within reacquire_gate_sigmas of
  // its horizontal sigma plus reacquire_margin, yaw within as many yaw sigmas plus
  // reacquire_yaw_margin. A look-alike elsewhere in the map (a stale GNSS prior, a symmetric
  // intersection) is refused and counted; a filter that is itself wrong is reset by the GNSS
  // divergence monitor or the basin audit, and its cold start is not gated.
  double reacquire_gate_sigmas = 4.0;        // [sigma]
  double reacquire_margin = 1.0;             // [m]
  double reacquire_yaw_margin = 0.1;         // [rad] (5.7 deg)
  double gnss_divergence_distance = 30.0;    // [m] lost track: fix farther than max(this, sigmas * h_acc)
  double gnss_divergence_sigmas = 6.0;       // [sigma] ... in reported h_acc
  std::uint32_t gnss_divergence_fixes = 10;  // [fixes] in a row -> restart globally (2 s at 5 Hz)
  double stereo_covariance_scale = 25.0;     // [ratio] stereo covariance over the ICP's (TUNING.md)
  bool use_odometry = true;                  // [switch] fuse the LiDAR odometry's relative motion
  // [switch] evaluation only: an ungated second filter for the paper's "Fused" column (ECU: off)
  bool shadow_ungated_filter = false;

  static ValidityGateParams default_gate() {
    ValidityGateParams p;
    p.min_fitness = 0.3;            // [0-1] a registration with a lower ICP fitness is not fused (TUNING.md)
    // [m] a registration with a higher inlier RMSE is not fused (TUNING.md)
    p.max_rmse = 0.53;
    return p;
  }
};

// FrameOutput (frame_output.hpp).
struct FrameOutputParams {
  double localized_sigma_xy = 0.10;   // [m] fused 1-sigma budget (Reid et al. 2019 local street)
  double road_height_radius = 70.0;   // [m] before the filter: road height of the map within this of the fix
  std::uint32_t road_height_min_points = 50;  // [points] in the 0.2 m bin to output the road height
};

struct LocalizerParams {
  // ---- The Localizer's own ----
  // [instructions] per-period estimate; rebuild steps and the audit take only what is left (period_work.hpp)
  PeriodWorkParams work = default_work();
  double odometry_prediction_max_gap = 1.0;  // [s] frame gap up to which the signals predict odometry
  // [clouds/period] map clouds taken per period while tracking (start-up: the caller's schedule; 0: no limit)
  std::uint32_t map_clouds_per_period_tracking = 1;
  // [switch] no map clouds after the first map until the first acquisition ends (TUNING.md)
  bool defer_map_clouds_first_search = true;
  // [switch] fuse wheel speed / yaw rate; deskew and predict with them (ScanPreparation, PoseFilter)
  bool use_vehicle_signals = true;
  bool use_stereo = false;            // [switch] register and fuse the stereo cloud while tracking

  // ---- The stages, in on_ego_scan's order ----
  ScanPreparationParams scan{};
  OdometryParams odometry = default_odometry();  // KISS-ICP-style LiDAR odometry (odometry.hpp)
  ReferenceMapParams map{};
  StartupSearchParams startup{};
  TrackingParams tracking{};
  BasinAuditParams audit{};
  GnssCourseParams course{};
  PoseFilterParams filter{};
  FrameOutputParams output{};

  static PeriodWorkParams default_work() {
    PeriodWorkParams p;  // per-unit costs: callgrind, x86-64 -O2, Sim 0 / 4_infra_2_agent (TUNING.md)
    // EMBEDDED's own, measured on its build (TUNING.md "Period budget"): a 4,096-voxel ingest
    // read costs ~6.8 M, and its odometry map (2 points a voxel) ~3.3 M a frame + ~310 a query.
    p.scan = config::kEmbeddedProfile ? 8.5e6 : 10.5e6;  // [instructions] per read of the sweep
    p.odometry_frame = config::kEmbeddedProfile ? 4.5e6 : 0.0;  // [instructions] per odometry frame
    p.odometry_query = config::kEmbeddedProfile ? 400.0 : 2450.0;  // [instructions] per odometry point and iteration
    p.tracking_query = 2300.0;  // [instructions] per tracking ICP point and pass
    p.evaluation_point = 1000.0;  // [instructions] per fitness-evaluation point (912 on a real 17.9k-point scan)
    p.map_normal = 5000.0;      // [instructions] per map normal
    p.search_unit = 150.0;      // [instructions] per search unit: the dear end of the measured 77-170
    return p;
  }
  static OdometryParams default_odometry() {
    OdometryParams p;
    // [point-iterations] per frame, ~40 M instructions; the rest counted odometry_query_capped
    p.max_queries = 16384;
    // [points] a frame is thinned evenly to at most this many (counted odometry_frames_thinned)
    p.max_fine_points = 16384;
    p.fine_decimation = 2;  // [stride] every 2nd 0.5 v point (TUNING.md)
    p.convergence = 1e-3;  // [m, rad] stop once |d xi| is below this (TUNING.md)
    return p;
  }
};

}  // namespace v2xloc
