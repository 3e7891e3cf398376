// Every tuning value of the localizer, with units and reasons. Defaults are what v2xloc-eval
// runs; the ablations in the evaluation flip the switches at the bottom.
#pragma once

#include <cstdint>

#include "v2xloc/algo/localization/ekf.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/localization/map_fusion.hpp"
#include "v2xloc/algo/localization/odometry.hpp"
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
  double frame_period = 0.1;          // [s] LiDAR sweep period (deskew span)
  float min_range = 3.0f;             // [m] drops returns from the ego vehicle body
  float max_range = 80.0f;            // [m] far returns are sparse and noisy
  float registration_voxel = 0.5f;    // [m] ego scan downsampling for map registration

  // ---- Reference map ----
  MapFusionParams map{};              // voxel 0.2 m, consistency check on
  double map_refresh_period = 0.5;    // [s] rebuild map points / normals / tree at most this often
  // A rebuild runs beside the registration, one step per period: extract, k-d tree, then the
  // normals this many points per period (~25 M instructions on the host); registration keeps
  // the previous map meanwhile. The first map is built at once (nothing to register against).
  std::uint32_t map_normals_per_period = 32768;
  float map_normal_radius = 0.6f;     // [m] (3 map voxels)

  // ---- Odometry ----
  OdometryParams odometry{};

  // ---- Registration to the map ----
  IcpParams icp = default_icp();      // tracking: point-to-plane from the EKF prediction
  RegisterCloudsParams global = default_global();   // the paper's FPFH + RANSAC
  PoseSearchParams search = default_search();        // GNSS-seeded exhaustive search
  bool use_fpfh_ransac = true;        // try FPFH + RANSAC too; the better ICP fitness wins
  // Scan points the pose search (start-up, audit) refines and compares its candidates on: every
  // k-th point of the registration scan, <= config::kMaxSearchPoints. The accepted pose is refined
  // again on the whole scan; this only picks the basin (a 0.5 m-voxel scan holds 5-20k points).
  std::uint32_t search_points = 1024;
  double global_map_radius = 70.0;    // [m] map crop around the GNSS fix for the global search
  double global_gnss_gate_sigmas = 4.0;  // accept a global solution within this many GNSS sigmas
  // ... but never closer than this [m]: a canyon receiver reports sigma_uere * HDOP (3-8 m) while
  // NLOS errors reach 20-30 m (host_sim GNSS: mean 8-17 m, max 32 m); a region built from the
  // reported sigma excluded the true pose (measured at Sim 0's first frames).
  double global_min_region = 30.0;
  double global_min_fitness = 0.3;    // and with at least this ICP fitness
  // Before the filter starts, the output's height is the map's road surface within
  // global_map_radius of the fix when at least this many map points lie in its 0.2 m bin.
  std::uint32_t road_height_min_points = 50;
  // ... and distinct: runner-up basin's tight fitness / winner's below this. Far from the
  // intersection the sparse map makes aliased poses along the street nearly as good; we wait
  // (GNSS only) until the answer is unambiguous instead of locking onto a wrong basin.
  double global_max_ambiguity = 0.85;
  // [m] a registration above this inlier RMSE is a failure. Off by default: at a 1 m inlier
  // threshold the RMSE of a correct alignment is 0.3-0.5 m (scan parts the map lacks still find
  // a neighbour), so it does not separate good from bad; the validity gate does that.
  double max_inlier_rmse = 1e9;
  double tracking_max_sigma_xy = 0.5; // [m] EKF position sigma above which we search globally
  std::uint32_t max_failed_frames = 10;  // consecutive unfused registrations -> global search
  std::uint32_t global_retry_frames = 2;  // frames between two global searches (bounded cost)
  // A global solution starts the filter only when a second, independent search within this many
  // frames agrees with it through the odometry's relative motion. Why: a straight street matches
  // itself turned by 180 deg; such a flipped pose predicts the opposite motion and fails the
  // check within a metre of travel (measured: an unconfirmed flip at Sim 3's approach tracked
  // backwards for 10 s). Until confirmed the output is the candidate, flagged not localized.
  // 0: the first accepted search starts the filter.
  std::uint32_t global_confirm_window = 10;
  double global_confirm_distance = 0.5;   // [m] horizontal disagreement allowed
  double global_confirm_yaw = 0.035;      // [rad] (2 deg) heading disagreement allowed
  // Basin audit while tracking: every audit_period frames an exhaustive pose search within
  // audit_radius of the tracked pose; a distinct pose explaining clearly more of the scan at the
  // tight threshold (ratio) means tracking sits in an aliased basin (facade detail repeats along
  // a street; measured: a 4 m offset tracked at fitness 0.7 through Sim 3's intersection). The
  // filter then restarts from that pose once a global search confirms it. 0: off.
  std::uint32_t audit_period_frames = 10;
  double audit_radius = 8.0;              // [m]
  double audit_switch_ratio = 1.15;
  // Ambiguity resolution by the GNSS track: when the two best basins explain the scan equally
  // well (a symmetric intersection matches itself turned by 180 deg some 25 m away), each is
  // carried back along the odometry track of the last frames and compared with the GNSS fixes
  // there; the one whose track is closer on average wins if it is closer by both a factor and a
  // margin. Many fixes average the canyon's NLOS errors down; one fix does not.
  std::uint32_t track_frames = 30;           // <= kTrackFrames (3 s at 10 Hz)
  std::uint32_t track_min_fixes = 10;        // frames with a fix needed to decide
  double track_distance_ratio = 0.6;         // winner's mean distance < ratio * loser's
  double track_distance_margin = 5.0;        // [m] and smaller by at least this
  // Any global solution whose track lies farther than this from the fixes on average is wrong
  // (the canyon's mean GNSS error is 8-17 m); one without enough fixes yet is kept as a
  // candidate but not output (the GNSS fix is).
  double track_max_distance = 25.0;          // [m]
  // Start-up heading from the GNSS Doppler velocity: while the vehicle drives forward, the course
  // over ground is its heading (antenna on the body axis, side slip of a car at urban speeds
  // < 2 deg). Doppler survives the canyon far better than the position does (an NLOS range rate
  // is biased only by the motion towards the reflecting facade: measured 1-3 deg mean error where
  // the position is 8-17 m off), so it rules out the intersection's 180-deg mirror at the first
  // frame instead of after 3 s of GNSS track. Used as a yaw window on the global search.
  bool use_gnss_heading = true;
  double heading_min_speed = 3.0;         // [m/s] Doppler speed and wheel speed both above this
  double heading_max_sigma = 0.17;        // [rad] reported course sigma atan(speed_acc / speed)
  double heading_max_age = 1.0;           // [s] a course older than this is not used
  double heading_search_tolerance = 0.79; // [rad] (45 deg) yaw window around the course
  // A candidate found with that yaw window is output before confirmation (as a GNSS-track-
  // checked one is): it cannot be the mirror, and it is centimetres, not metres, off.
  // Lost-track monitor: this many GNSS fixes in a row farther from the filter than
  // max(distance, sigmas * reported h_acc) mean the filter, not the GNSS, is wrong (canyon fixes
  // are off by 8-17 m on average, rarely 30 m, never for seconds in a row): restart globally.
  double gnss_divergence_distance = 30.0;  // [m]
  double gnss_divergence_sigmas = 6.0;
  std::uint32_t gnss_divergence_fixes = 10;  // 2 s at 5 Hz

  // ---- Stereo modality (LiDAR + stereo configuration) ----
  // While tracking, the stereo cloud is registered to the map like the LiDAR scan (own ICP from
  // the same prediction, own causal validity gate) and fused as a second pose measurement whose
  // covariance uses max(inlier RMSE, mean depth sigma): z-noise grows with z^2 (stereo_cloud.hpp),
  // so points beyond max_depth_sigma are dropped and the rest weigh by their noise.
  bool use_stereo = false;
  StereoParams stereo = default_stereo();
  float stereo_voxel = 0.3f;          // [m]
  std::uint32_t stereo_min_points = 200;
  // Stereo point-to-plane residuals are correlated along each disparity row (one matching error
  // moves a whole surface patch), so its ICP covariance is far more optimistic than LiDAR's:
  // measured 0.1-1.8 m errors at a few-cm ICP sigma on the 1/8-resolution rig.
  double stereo_covariance_scale = 25.0;
  IcpParams stereo_icp = default_icp();

  // ---- Validity gate and fusion ----
  GateMode gate_mode = GateMode::kFixedLag;
  // The paper's envelope test plus one absolute floor: below 30 % of the scan within 1 m of the
  // map, the map covers too little of the scan to pin the pose (measured on Sim 0 / 2_infra:
  // 20 of 24 registrations off by > 10 cm had fitness < 0.3, none of 159 within 3 cm did).
  ValidityGateParams gate = default_gate();
  EkfParams ekf{};
  RegistrationCovarianceParams registration_covariance{};
  std::uint32_t reset_after_rejections = 3;  // NIS-rejected registrations in a row -> restart
  double localized_sigma_xy = 0.10;   // [m] Reid et al. 2019 local-street budget, 1 sigma

  // ---- Switches (ablations) ----
  bool use_gnss = true;
  bool use_vehicle_signals = true;
  bool use_odometry = true;
  bool deskew = true;

  static IcpParams default_icp() {
    IcpParams p;
    p.method = IcpMethod::kPointToPlane;
    p.max_correspondence_distance = 1.0;
    p.criteria.max_iterations = 20;
    // Stop once an iteration changes the fitness by < 1e-5 and the RMSE by < 10 um: from the
    // EKF prediction that takes 4-8 iterations; at 1e-7 nearly every frame ran all 20 (each a
    // nearest-neighbour pass over the scan) for sub-millimetre changes.
    p.criteria.relative_fitness = 1e-5;
    p.criteria.relative_rmse = 1e-5;
    p.kernel.type = RobustKernelType::kTukey;
    p.kernel.scale = 0.3;
    return p;
  }
  static RegisterCloudsParams default_global() {
    RegisterCloudsParams p;
    p.mode = RegistrationMode::kGlobal;
    p.voxel_size = 1.0f;            // the map is sparse far from the sensors: coarse descriptors
    p.mutual_filter = false;        // mutual matching leaves too few pairs on sparse maps
    p.ransac.prior.enabled = true;  // hypotheses must be level and inside the GNSS region
    p.ransac.prior.max_tilt = 0.087;  // [rad] 5 deg
    return p;
  }
  static ValidityGateParams default_gate() {
    ValidityGateParams p;
    p.min_fitness = 0.3;
    // With the tracking ICP's 1 m gate, residuals spread evenly over the gate give an RMSE near
    // 0.58 m: the scan sits off the map's basin (leaving the mapped area, the fit slides by
    // 0.1-0.3 m). Over the 12 recordings 311 of 319 tracking registrations that were > 0.1 m
    // off had RMSE > 0.53 m, 144 of 1983 good ones did (measured with this limit off).
    p.max_rmse = 0.53;              // [m]
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
    p.icp.max_correspondence_distance = 2.0;  // the grid is 2.5 m / 7.5 deg coarse
    p.icp.criteria.max_iterations = 30;
    p.icp.kernel.type = RobustKernelType::kTukey;
    p.icp.kernel.scale = 1.0;
    p.yaw_steps = 24;               // 15 deg; the coarse ICP pulls in +-7.5 deg
    p.step = 3.0;
    p.radius = 30.0;                // [m] = global_min_region (bounded work: ~8k hypotheses)
    p.score_points = 96;
    // Half the grid cell's diagonal (step 3 m): with 1 m the true pose's cell, 1.5 m off, scored
    // 0.1 and was not shortlisted (Sim 0's first frame); the aliases this lets in are removed
    // by the ray check below.
    p.score_distance = 2.0;
    // Poses whose rays cross the map's walls are not candidates (pose_search.hpp): the street's
    // aliases 21-30 m along it fit the facades as well as the truth but look through them.
    p.max_conflicts = 0.12;
    p.fine_icp = default_icp();
    return p;
  }
};

}  // namespace v2xloc
