// Every tuning value of the localizer, with units and reasons. Defaults are what v2xloc-eval
// runs; the ablations in the evaluation flip the switches at the bottom.
#pragma once

#include <cstdint>

#include "v2xloc/algo/ekf.hpp"
#include "v2xloc/algo/icp.hpp"
#include "v2xloc/algo/map_fusion.hpp"
#include "v2xloc/algo/odometry.hpp"
#include "v2xloc/algo/pose_search.hpp"
#include "v2xloc/algo/register_clouds.hpp"
#include "v2xloc/algo/validity_gate.hpp"

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
  float map_normal_radius = 0.6f;     // [m] (3 map voxels)

  // ---- Odometry ----
  OdometryParams odometry{};

  // ---- Registration to the map ----
  IcpParams icp = default_icp();      // tracking: point-to-plane from the EKF prediction
  RegisterCloudsParams global = default_global();   // the paper's FPFH + RANSAC
  PoseSearchParams search = default_search();        // GNSS-seeded exhaustive search
  bool use_fpfh_ransac = true;        // try FPFH + RANSAC too; the better ICP fitness wins
  double global_map_radius = 70.0;    // [m] map crop around the GNSS fix for the global search
  double global_gnss_gate_sigmas = 4.0;  // accept a global solution within this many GNSS sigmas
  double global_min_fitness = 0.3;    // and with at least this ICP fitness
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

  // ---- Validity gate and fusion ----
  GateMode gate_mode = GateMode::kFixedLag;
  ValidityGateParams gate{};
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
    p.criteria.relative_fitness = 1e-7;
    p.criteria.relative_rmse = 1e-7;
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
  static PoseSearchParams default_search() {
    PoseSearchParams p;
    p.icp.method = IcpMethod::kPointToPlane;
    p.icp.max_correspondence_distance = 2.0;  // the grid is 2.5 m / 7.5 deg coarse
    p.icp.criteria.max_iterations = 30;
    p.icp.kernel.type = RobustKernelType::kTukey;
    p.icp.kernel.scale = 1.0;
    p.yaw_steps = 24;               // 15 deg; the coarse ICP pulls in +-7.5 deg
    p.step = 3.0;
    p.score_points = 96;
    p.fine_icp = default_icp();
    return p;
  }
};

}  // namespace v2xloc
