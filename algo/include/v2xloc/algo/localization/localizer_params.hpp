// Every tuning value of the localizer: one line each, unit and rule. Defaults are what v2xloc-eval
// runs; the ablations flip the switches at the bottom. Why a value is what it is, measured on
// which recording: algo/TUNING.md.
#pragma once

#include <cstdint>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/ekf.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/localization/map_fusion.hpp"
#include "v2xloc/algo/localization/odometry.hpp"
#include "v2xloc/algo/localization/period_work.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"
#include "v2xloc/algo/registration/register_clouds.hpp"
#include "v2xloc/algo/localization/stereo_cloud.hpp"
#include "v2xloc/algo/localization/validity_gate.hpp"

namespace v2xloc {

enum class GateMode : std::uint8_t {
  kFixedLag,  // paper's centred window; a registration is fused w/2 frames late, at its stamp
  kCausal,    // past window only; fused immediately
  kOff,       // every successful registration is fused (the paper's "Fused" column)
};

struct LocalizerParams {
  // ---- Scan preprocessing ----
  double frame_period = 0.1;          // [s] LiDAR sweep period: deskew span and vehicle-signal delta
  float min_range = 3.0f;             // [m] returns closer than this are the ego body: dropped
  float max_range = 80.0f;            // [m] returns farther than this are sparse and noisy: dropped
  float registration_voxel = 0.5f;    // [m] ingest voxel (LiDAR frame): odometry's 0.5 v frame and the registration scan
  // [points] the tracking ICP registers an even subsample of at most this many scan points
  // (one nearest-neighbour query each per iteration; 0: all). 1,500 (was 3,000): tracking -44 %
  // instructions, Fused (valid) within 1 mm on the 12 recordings (TUNING.md "Tracking subsample")
  std::uint32_t tracking_points = 1500;
  double odometry_prediction_max_gap = 1.0;  // [s] frame gap up to which the signals predict odometry

  // ---- Reference map ----
  MapFusionParams map{};              // fused infrastructure + agent clouds (map_fusion.hpp)
  // [s] rebuild map points / normals / tree at most this often (TUNING.md); the EMBEDDED profile's
  // 8,192-point map keeps 1 s (at 2 s its Fused (lag) rose to 0.034 m on Sim 2 / 4_infra)
  double map_refresh_period = config::kEmbeddedProfile ? 1.0 : 2.0;
  // [clouds/period] map clouds the localizer takes per period while tracking (its caller's share
  // schedule allows more at start-up, when the map is still being assembled; 0: no limit). One
  // fused cloud is ~20 M instructions (TUNING.md "Quiet periods").
  std::uint32_t map_clouds_per_period_tracking = 1;
  // Until the first acquisition is over (its searches' slices ignore the period budget; at most
  // startup_first_frames) the periods after the first map take no map clouds: they would reach
  // the map only at its next rebuild anyway, and two of them (~55 M) on top of a search put
  // start-up periods over 100 M (TUNING.md "Map clouds during the first acquisition"). Host
  // profile only: the EMBEDDED map, rebuilt every second, missed them (Fused (lag) 0.020 -> 0.036 m).
  bool defer_map_clouds_first_search = !config::kEmbeddedProfile;
  double map_refresh_quiet_wait = 0.5;  // [s] a due rebuild waits this long at most for a period without new clouds
  // [s] a source's cloud is fused at most this often (0: every cloud). The map is rebuilt at most
  // every map_refresh_period and takes each source's latest cloud, so of a 2 Hz source's clouds
  // only every other one would ever reach a rebuild; checking and storing the others is wasted
  // (TUNING.md). Just under the refresh period so a share of a 1 Hz (host: 0.5 Hz) cycle with
  // jitter is never skipped.
  double map_cloud_interval = config::kEmbeddedProfile ? 0.9 : 1.9;
  float map_normal_radius = 0.6f;     // [m] normal estimation radius on the map (3 map voxels)
  std::uint32_t map_min_points = 100; // [points] a map with fewer is not registered against
  // [points/period] a map rebuild runs beside the registration, one step per period (extract,
  // then k-d tree and vicinity bitmap); registration keeps the previous map meanwhile. The first
  // map is built at once (nothing to register against). Map normals are computed when an ICP
  // first matches a point (registration/lazy_normals.hpp, ~4k instructions each), at most this
  // many per period: a tracked frame needs ~1-3k on a fresh map, the start-up search more; past
  // the cap a pair goes without its normal this period (counted).
  std::uint32_t map_normals_per_period = 8192;
  // [point visits/period] the next map's k-d tree is built this much per period (a build
  // visits ~N log2(N / leaf) points; 0: at once)
  std::uint32_t map_tree_work_per_period = 125000;
  // [m] requested cell of the map's vicinity bitmap (search/proximity_grid.hpp; grows to fit the
  // map's box in config::kProximityGridWords): ICP queries it proves empty within the gate skip
  // the k-d tree (same matches); 0: off
  float map_vicinity_cell = 0.5f;

  // ---- Period budget ----
  // Estimated instructions per period (period_work.hpp): a map rebuild step waits for a period
  // with room (at most work.max_deferred_rebuild_steps), the basin audit takes what is left.
  PeriodWorkParams work = default_work();

  // ---- Odometry ----
  OdometryParams odometry = default_odometry();  // KISS-ICP-style LiDAR odometry (odometry.hpp)

  // ---- Registration to the map ----
  IcpParams icp = default_icp();      // tracking ICP: point-to-plane from the EKF prediction
  PoseSearchParams search = default_search();        // start-up GNSS-seeded exhaustive search
  // [points] the pose search (start-up, audit) refines and compares its candidates on every k-th
  // registration-scan point, <= config::kMaxSearchPoints; the accepted pose is refined again on
  // the whole scan (this only picks the basin; a 0.5 m-voxel scan holds 5-20k points).
  std::uint32_t search_points = 1024;
  double global_map_radius = 70.0;    // [m] map crop (and road-height disc) around the GNSS fix
  double global_gnss_gate_sigmas = 4.0;  // [sigma] start-up region radius in inflated GNSS sigmas (+1 m)
  double global_min_region = 30.0;    // [m] start-up region radius floor (canyon NLOS; TUNING.md)
  // [m] after an exhaustive search that found nothing acceptable the next one searches a region
  // global_region_growth times wider, up to this: a canyon fix can be further off than the floor
  // (TUNING.md "Widening start-up region"); back to the floor once a candidate is found
  double global_max_region = 45.0;
  double global_region_growth = 1.5;
  double global_max_vertical = 3.0;   // [m] RANSAC prior: hypothesis height off the road surface
  double global_min_fitness = 0.3;    // [0-1] start-up solution needs at least this ICP fitness
  // [0-0.5] a start-up solution needs its final ICP constrained along both horizontal directions
  // (RegistrationResult::horizontal_constraint): with too little of the map in view the scan's
  // matched facades leave it free along the street and an alias metres away fits as well
  // (TUNING.md "Along-street aliases": aliases 0.015-0.018, true poses 0.077-0.133). 0: off; off
  // in the EMBEDDED profile, whose thinner scans and map put true poses at 0.011-0.050.
  double global_min_horizontal_constraint = config::kEmbeddedProfile ? 0.0 : 0.04;
  std::uint32_t road_height_min_points = 50;  // [points] in the 0.2 m bin to output the road height
  double global_max_ambiguity = 0.85; // [0-1] runner-up / winner tight fitness above: ambiguous
  double max_inlier_rmse = 1e9;       // [m] registration above this RMSE fails (off; TUNING.md)
  double tracking_max_sigma_xy = 0.5; // [m] EKF position sigma above which we search globally
  std::uint32_t max_failed_frames = 10;   // [frames] consecutive unfused registrations -> global search
  std::uint32_t global_retry_frames = 2;  // [frames] between two global searches (bounded cost)
  // [work units/period] the start-up search runs as a job, at most this much work per period
  // (pose_search.hpp: ~110 instructions a unit) and no more than the period budget has left
  // (work), but at least startup_min_work_per_period; its result is carried to the frame it
  // finishes in by the odometry (0: all at once)
  std::uint32_t startup_work_per_period = 800000;
  std::uint32_t startup_min_work_per_period = 30000;
  // The first acquisition after power-up (until the filter first starts, at most
  // startup_first_frames); the localizer takes no map clouds past the first map meanwhile.
  std::uint32_t startup_first_frames = 10;  // [frames] since configure()
  // [work units/period] 0: the first acquisition keeps to the period budget like any search
  // (frame 0 81-97 M instructions on the 12 recordings), its climbed best hypothesis the output
  // until a refined pose replaces it (algo/TUNING.md, "Basin climb"). > 0: its searches take at
  // least this per period, budget or not (1.5M: the whole search and final ICP in frame 0,
  // ~105-160 M instructions, the refined pose the output from frame 0).
  std::uint32_t startup_first_work_per_period = 0;
  // Within the budget (startup_first_work_per_period 0), the searches' first slices score and
  // climb every hypothesis, budget or not (bounded: search.max_hypotheses x score_points lookups
  // plus the climbs, ~8-20 M instructions) and the best climbed pose is output until a refined
  // one replaces it (0.1-1.2 m off on the 12 recordings, the refined one from frame 1-2).
  bool startup_first_score_whole = true;
  std::uint32_t startup_max_frames = 20;  // [frames] a search job not finished within this is dropped
  // While a spread search runs, output its best refined pose so far (not localized, not fused).
  bool startup_output_provisional = true;
  // The confirming search re-decides the candidate's search finalists (carried by the odometry)
  // on its later scan instead of searching the whole region again.
  bool global_confirm_finalists = true;
  bool startup_icp_on_tracking_scan = true;  // an accepted pose's final ICP on the tracking subsample
  // The start-up search scores its hypotheses on a proximity bitmap of the searched region (~35
  // instructions a score point against ~1000 for the map's k-d tree; search.grid_cell).
  bool search_on_proximity_grid = true;
  std::uint32_t global_confirm_window = 10;  // [frames] a second search within this confirms (0: off)
  double global_confirm_distance = 0.5;   // [m] confirmation: horizontal disagreement allowed
  double global_confirm_yaw = 0.035;      // [rad] confirmation: heading disagreement allowed (2 deg)
  // [frames] from one basin audit's end to the next start while tracking (0: off); an audit
  // costs ~270 M instructions in all, so every 3 s keeps its share of a period near 8 M
  std::uint32_t audit_period_frames = 30;
  // [frames] a new track's first audit starts after this many tracked frames, with all the room
  // the period budget has left: a start-up search on a map that lost a unit's shares can accept
  // an alias the full map refutes (TUNING.md "Basin audit of a new track")
  std::uint32_t audit_first_frames = 1;
  double audit_radius = 8.0;              // [m] basin audit: search disc around the tracked pose
  // [work units/period] the audit's pose search runs beside tracking, this much work per tracked
  // frame (pose_search.hpp: ~110 instructions a unit, so ~10 M; 0: the whole search in one frame)
  std::uint32_t audit_work_per_period = 90000;
  // [work units/period] ... in a period that fused a map cloud (~20 M of its budget spent; 0: the
  // audit pauses there). While tracking most periods fuse one (sources paced to ~1 Hz, one a period).
  std::uint32_t audit_work_per_busy_period = 45000;
  std::uint32_t audit_max_frames = 60;    // [frames] a search not finished within this is dropped (it pauses in busy periods)
  // [hypotheses] the audit refines (<= kPoseSearchRefine): 5 as the start-up search; 10 cost twice
  // the ICP work for the same verdicts on the 12 recordings and the fault and rogue runs (TUNING.md)
  std::uint32_t audit_refine_candidates = 5;
  double audit_switch_ratio = 1.15;       // [ratio] audit pose's tight fitness over tracked: switch
  double audit_full_switch_ratio = 1.15;  // [ratio] ... and again on the full scan after ICP: switch
  std::uint32_t track_frames = 30;        // [frames] GNSS track compared (<= kTrackFrames)
  std::uint32_t track_min_fixes = 10;     // [fixes] needed in the track to decide
  double track_distance_ratio = 0.6;      // [ratio] winner's mean track distance < ratio * loser's
  double track_distance_margin = 5.0;     // [m] ... and smaller by at least this
  double track_max_distance = 25.0;       // [m] a solution whose track is farther is wrong
  bool use_gnss_heading = true;           // GNSS course over ground as start-up yaw window
  double heading_min_speed = 3.0;         // [m/s] Doppler and wheel speed both above this
  double heading_max_sigma = 0.17;        // [rad] course sigma atan(speed_acc / speed) at most this
  double heading_max_age = 1.0;           // [s] a course older than this is not used
  double heading_search_tolerance = 0.79; // [rad] yaw window half-width around the course (45 deg)
  double gnss_divergence_distance = 30.0; // [m] lost track: fix farther than max(this, sigmas * h_acc)
  double gnss_divergence_sigmas = 6.0;    // [sigma] ... in reported h_acc
  std::uint32_t gnss_divergence_fixes = 10;  // [fixes] in a row -> restart globally (2 s at 5 Hz)

  // ---- Stereo modality (LiDAR + stereo configuration) ----
  bool use_stereo = false;            // register and fuse the stereo cloud while tracking
  StereoParams stereo = default_stereo();  // disparity -> cloud (stereo_cloud.hpp)
  float stereo_voxel = 0.3f;          // [m] stereo cloud downsampling
  std::uint32_t stereo_min_points = 200;   // [points] fewer after downsampling: not registered
  double stereo_covariance_scale = 25.0;   // [ratio] stereo covariance over the ICP's (TUNING.md)
  IcpParams stereo_icp = default_icp();    // stereo ICP from the same prediction

  // ---- Validity gate and fusion ----
  GateMode gate_mode = GateMode::kFixedLag;  // which validity gate feeds the EKF
  ValidityGateParams gate = default_gate();  // paper's envelope + absolute floors (TUNING.md)
  EkfParams ekf{};                           // filter noise and NIS gates (ekf.hpp)
  RegistrationCovarianceParams registration_covariance{};  // ICP information -> pose covariance
  std::uint32_t reset_after_rejections = 3;  // [registrations] NIS-rejected in a row -> restart
  double localized_sigma_xy = 0.10;   // [m] fused 1-sigma budget (Reid et al. 2019 local street)
  // [m, m, m, rad, m/s, rad/s, rad/s, -] 1-sigma of each state (ekf_index order) at a (re)start.
  double restart_sigmas[kEkfStateSize] = {0.1, 0.1, 0.1, 0.01, 0.5, 0.05, 0.005, 0.02};

  // ---- Switches (ablations) ----
  bool use_gnss = true;               // fuse GNSS fixes (and use them for track checks)
  bool use_vehicle_signals = true;    // fuse wheel speed / yaw rate; deskew and predict with them
  bool use_odometry = true;           // fuse the LiDAR odometry's relative motion
  bool deskew = true;                 // deskew scans with per-point times
  // Evaluation only: a second filter fed every ok registration (no validity gate), for the paper's
  // "Fused" column (LocalizerFrameOutput::fused_pose_ungated). The ECU leaves it off.
  bool shadow_ungated_filter = false;

  static PeriodWorkParams default_work() {
    PeriodWorkParams p;  // per-unit costs: callgrind, x86-64 -O2, Sim 0 / 4_infra_2_agent (TUNING.md)
    p.odometry_query = 2450.0;
    p.tracking_query = 2300.0;
    p.map_normal = 5000.0;
    p.search_unit = 150.0;  // kPoseSearchWorkUnit's ~110 is a mean: slices measured up to ~170 a unit
    return p;
  }
  static OdometryParams default_odometry() {
    OdometryParams p;
    // [queries] ~40 M instructions at ~2,450 a query: the recordings' frames need <= ~12.5k
    // (capped in 2-15 frames a recording, Table 1 within 1 mm); a featureless corridor ran 50
    // iterations (100 M)
    p.max_queries = 16384;
    // [points] the recordings' frames hold ~7k 0.5 m points; a noise-filled sweep 32k (55 M of
    // set-up: coarse voxels, normals, map update)
    p.max_fine_points = 16384;
    // Every 2nd 0.5 v point (host): odometry -5.6 M a period, SLAM column 0.015-0.065 m (was
    // 0.024-0.088), Fused within ~1 mm (TUNING.md "Odometry on every 2nd point"); every 3rd
    // broke Sim 3 (SLAM 0.47 m)
    p.fine_decimation = config::kEmbeddedProfile ? 1u : 2u;
    p.convergence = 1e-3;  // [m, rad] |d xi| stop; 1e-4 ran ~2 more iterations for nothing (TUNING.md)
    return p;
  }
  static IcpParams default_icp() {
    IcpParams p;
    p.method = IcpMethod::kPointToPlane;
    p.max_correspondence_distance = 1.0;  // [m] tracking gate around the EKF prediction
    p.criteria.max_iterations = 20;       // [iterations] cap (one nearest-neighbour pass each)
    // [-] stop once an iteration changes the fitness by < 1e-3 and the RMSE by < 1 mm (TUNING.md)
    p.criteria.relative_fitness = 1e-3;
    p.criteria.relative_rmse = 1e-3;      // [m]
    p.kernel.type = RobustKernelType::kTukey;
    p.kernel.scale = 0.3;                 // [m] Tukey scale: residuals beyond it weigh nothing
    // [work units] ~44 M instructions: the recordings' tracking ICPs stay below ~28 M; a
    // featureless corridor (degenerate along it, every pass computing new map normals) took 175 M
    p.max_work = 400000;
    return p;
  }
  static ValidityGateParams default_gate() {
    ValidityGateParams p;
    p.min_fitness = 0.3;            // [0-1] a registration with a lower ICP fitness is not fused (TUNING.md)
    // [m] a registration with a higher inlier RMSE is not fused: below the ~0.58 m of residuals
    // spread evenly over the tracking ICP's 1 m gate, i.e. of a scan off the map's basin (TUNING.md)
    p.max_rmse = 0.53;
    return p;
  }
  static StereoParams default_stereo() {
    StereoParams p;
    p.stride = 4;                   // every 4th pixel in u and v: ~1/16 of the image
    p.min_disparity = 2.0;          // [px]
    p.disparity_sigma = 0.5;        // [px] overridden by the calibration's value when known
    p.max_depth_sigma = 0.3;        // [m] ~15-20 m range for the ego rig
    return p;
  }
  static PoseSearchParams default_search() {
    PoseSearchParams p;
    p.icp.method = IcpMethod::kPointToPlane;
    p.icp.max_correspondence_distance = 2.0;  // [m] coarse ICP gate: about half a grid cell's diagonal
    p.icp.criteria.max_iterations = 20;      // [iterations]
    p.icp.criteria.relative_fitness = 1e-3;  // [-] the coarse ICP only picks the basin
    p.icp.criteria.relative_rmse = 1e-3;     // [m]
    p.icp.kernel.type = RobustKernelType::kTukey;
    // [m] Tukey scale of the coarse ICP = its gate: a hypothesis starts up to ~2 m from its basin's
    // bottom, and at 1 m the residuals that would pull it there weighed nothing (TUNING.md)
    p.icp.kernel.scale = 2.0;
    p.yaw_steps = 24;               // [headings] 15 deg apart; the coarse ICP pulls in +-7.5 deg
    p.step = 3.0;                   // [m] position grid spacing
    p.radius = 30.0;                // [m] = global_min_region (bounded work: ~8k hypotheses)
    p.score_points = 64;            // [points] scan points scored per hypothesis (the climb re-ranks on 256)
    p.refine_candidates = 5;        // [hypotheses] the best distinct ones refined by ICP
    p.climb_points = 256;           // [points] the kept hypotheses climb to their basins' bottoms (TUNING.md)
    p.refine_min_score_ratio = 0.8; // [0-1] and only those within 20 % of the best climbed score are refined
    // [points] the ICPs run on every 4th search point; EMBEDDED scans (4,096 ingest voxels) are
    // too thin for that: all of them (TUNING.md)
    p.refine_points = config::kEmbeddedProfile ? 0u : 256u;
    p.score_distance = 2.0;         // [m] score hit radius: half the grid cell's diagonal (TUNING.md)
    p.max_conflicts = 0.12;         // [0-1] ray conflict ratio above which a pose is no candidate (TUNING.md)
    p.fine_icp = default_icp();
    p.fine_icp.criteria.relative_fitness = 1e-5;  // [-] the search's candidates are compared on
    p.fine_icp.criteria.relative_rmse = 1e-5;     // [m] their converged fitness: converge fully
    return p;
  }
};

}  // namespace v2xloc
