// Bare-metal link check: runs every stage of algo/ on a tiny synthetic scene held in static
// storage (a box corner: floor and two walls, plus a transformed copy), so the linker proves the
// core needs no heap, no exceptions and no OS. Registration (downsample, k-d tree, normals, FPFH,
// correspondences, RANSAC, ICP, Kabsch) and localization (map fusion with a surveyed background
// held as the firmware holds it, deskew, LiDAR odometry, validity gate, EKF, geodesy, stereo cloud). The Localizer object itself is not linked: it owns a
// copy of every stage's storage plus its frame buffers (the target image under
// firmware/baremetal/target runs it); the stages below are the same code.
// Prints nothing; results go to volatile sinks so nothing is optimised away.
#include <algorithm>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/deskew.hpp"
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/localization/ekf.hpp"
#include "v2xloc/algo/core/geodesy.hpp"
#include "v2xloc/algo/registration/kabsch.hpp"
#include "v2xloc/algo/localization/map_fusion.hpp"
#include "v2xloc/algo/localization/odometry.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"
#include "v2xloc/algo/core/prng.hpp"
#include "v2xloc/algo/registration/register_clouds.hpp"
#include "v2xloc/algo/localization/stereo_cloud.hpp"
#include "v2xloc/algo/localization/surveyed_background.hpp"
#include "v2xloc/algo/localization/trajectory_backfill.hpp"
#include "v2xloc/algo/localization/validity_gate.hpp"

namespace {

constexpr std::size_t kScenePoints = 1536;
v2xloc::Vec3f g_target[kScenePoints];
v2xloc::Vec3f g_source[kScenePoints];
v2xloc::RegistrationWorkspace g_workspace;
// Localization stages: each owns its bounded storage (static, never on the small stack).
v2xloc::MapFusion g_map;
v2xloc::FixedVector<v2xloc::Vec3f, v2xloc::config::kMaxMapPoints> g_map_points;
v2xloc::LidarOdometry g_odometry;
v2xloc::OdometryScanBuffers g_odometry_buffers;
v2xloc::Ekf g_ekf;
v2xloc::FixedLagValidityGate g_fixed_lag_gate;
v2xloc::CausalValidityGate g_causal_gate;
v2xloc::TrajectoryBackfill g_backfill;
// Surveyed backgrounds at the firmware's capacity (firmware/wire/background_store.hpp), so the
// image's static RAM counts them.
std::uint32_t g_background_cells[v2xloc::config::kMaxBackgroundUnits][v2xloc::config::kMaxBackgroundCells];
float g_sweep_times[kScenePoints];
v2xloc::Vec3f g_deskewed[kScenePoints];
constexpr std::uint32_t kStereoWidth = 32, kStereoHeight = 24;
float g_disparity[kStereoWidth * kStereoHeight];
std::uint16_t g_disparity_fixed[kStereoWidth * kStereoHeight];
v2xloc::Vec3f g_stereo_points[kStereoWidth * kStereoHeight];
float g_stereo_sigma[kStereoWidth * kStereoHeight];
volatile double g_sink;
volatile std::uint32_t g_status;
volatile std::uint32_t g_localization_status;

// Floor z=0, walls x=0 and y=0 over a 4 m cube corner, plus a pole; jittered by the PRNG.
void make_scene() {
  v2xloc::Pcg32 rng(2024);
  for (std::size_t i = 0; i < kScenePoints; ++i) {
    const double u = rng.uniform(0.0, 4.0), v = rng.uniform(0.0, 4.0);
    v2xloc::Vec3d p;
    switch (i % 4) {
      case 0: p = v2xloc::Vec3d(u, v, 0.0); break;
      case 1: p = v2xloc::Vec3d(0.0, u, v * 0.5); break;
      case 2: p = v2xloc::Vec3d(u, 0.0, v * 0.5); break;
      default: {
        const double a = rng.uniform(-v2xloc::det::kPi, v2xloc::det::kPi);
        p = v2xloc::Vec3d(2.0 + 0.1 * v2xloc::det::cos(a), 2.0 + 0.1 * v2xloc::det::sin(a), v * 0.5);
      }
    }
    g_target[i] = p.cast<float>();
  }
  // Source = T^-1 target with T a yaw of 0.3 rad and a 0.4 m shift.
  const double c = v2xloc::det::cos(0.3), s = v2xloc::det::sin(0.3);
  for (std::size_t i = 0; i < kScenePoints; ++i) {
    const v2xloc::Vec3d q = g_target[i].cast<double>() - v2xloc::Vec3d(0.4, -0.2, 0.0);
    g_source[i] = v2xloc::Vec3f(static_cast<float>(c * q.x() + s * q.y()),
                                static_cast<float>(-s * q.x() + c * q.y()), static_cast<float>(q.z()));
  }
}

// Unit 1's surveyed background: its own cloud's 0.5 m cells, sorted.
v2xloc::SurveyedBackground survey_background(std::span<const v2xloc::Vec3f> cloud) {
  std::uint32_t* cells = g_background_cells[0];
  std::size_t n = 0;
  for (const v2xloc::Vec3f& p : cloud) {
    if (n < v2xloc::config::kMaxBackgroundCells && v2xloc::background_cell_key(p, 2.0, cells[n])) ++n;
  }
  std::sort(cells, cells + n);
  n = static_cast<std::size_t>(std::unique(cells, cells + n) - cells);
  return v2xloc::SurveyedBackground{0.5, std::span<const std::uint32_t>(cells, n)};
}

// Reference map from two "infrastructure" clouds, then the merged map on the voxel grid; unit 1
// checked against its surveyed background.
std::uint32_t fuse_map(std::span<const v2xloc::Vec3f> target, std::span<const v2xloc::Vec3f> source,
                       const v2xloc::Mat4d& target_T_source) {
  const bool surveyed = g_map.set_background(1, survey_background(target));
  const v2xloc::MapInsertResult a = g_map.insert(1, 0.0, v2xloc::Pose3d::Identity(), target, true);
  const v2xloc::MapInsertResult b = g_map.insert(2, 0.05, v2xloc::Pose3d(target_T_source), source);
  g_map.expire(0.1);
  const v2xloc::MapExtractResult merged = g_map.extract(g_map_points);
  return static_cast<std::uint32_t>(a.status) | (static_cast<std::uint32_t>(b.status) << 4) |
         (surveyed ? 1u << 8 : 0u) | (merged.points << 9);
}

// Deskews the source as a 0.1 s sweep, then two LiDAR odometry frames (target, deskewed source).
v2xloc::OdometryResult run_odometry(std::span<const v2xloc::Vec3f> target,
                                    std::span<const v2xloc::Vec3f> source) {
  for (std::size_t i = 0; i < kScenePoints; ++i) {
    g_sweep_times[i] = 0.1f * static_cast<float>(i) / static_cast<float>(kScenePoints);
  }
  v2xloc::Mat4d delta = v2xloc::Mat4d::Identity();
  delta(0, 3) = 0.5;  // 5 m/s over the 0.1 s frame period
  v2xloc::DeskewParams deskew_params;
  deskew_params.reference_time = 0.1;
  const v2xloc::DeskewResult d =
      v2xloc::deskew(source, std::span<const float>(g_sweep_times, kScenePoints), delta,
                     deskew_params, std::span<v2xloc::Vec3f>(g_deskewed, kScenePoints));
  v2xloc::OdometryParams params;
  params.voxel_size = 0.2;
  params.max_range = 20.0;
  params.min_range = 0.1;
  g_odometry.configure(params);
  g_odometry.register_frame(target, g_odometry_buffers);
  return g_odometry.register_frame(std::span<const v2xloc::Vec3f>(g_deskewed, d.points_out), g_odometry_buffers);
}

// A few frames of registration quality through both validity-gate variants.
std::uint32_t run_gates(const v2xloc::RegistrationResult& registration) {
  std::uint32_t valid = 0;
  for (std::uint32_t i = 0; i < 8; ++i) {
    v2xloc::GateSample sample;
    sample.fitness = registration.fitness - (i == 4 ? 0.3 : 0.0);  // one bad frame
    sample.rmse = registration.inlier_rmse;
    sample.ok = registration.ok();
    valid += g_causal_gate.push(sample).valid ? 1u : 0u;
    valid += g_fixed_lag_gate.push(sample).valid ? 1u : 0u;
  }
  for (v2xloc::GateDecision d = g_fixed_lag_gate.flush(); d.available; d = g_fixed_lag_gate.flush()) {
    valid += d.valid ? 1u : 0u;
  }
  return valid;
}

// Geodesy round trip: a GNSS fix (geodetic) -> local ENU -> geodetic again.
v2xloc::Vec3d gnss_fix_enu(double& roundtrip_error_deg) {
  const v2xloc::GeodeticOrigin origin = v2xloc::make_geodetic_origin(48.1374, 11.5755, 520.0);
  v2xloc::GeodeticPoint fix;
  fix.lat_deg = 48.13741;
  fix.lon_deg = 11.57551;
  fix.alt_m = 521.0;
  const v2xloc::Vec3d enu = v2xloc::geodetic_to_enu(origin, fix);
  const v2xloc::EcefToGeodeticResult back = v2xloc::enu_to_geodetic(origin, enu);
  roundtrip_error_deg = back.point.lat_deg - fix.lat_deg;
  return enu;
}

// Stereo disparity (float and fixed-point) of a fronto-parallel wall 8 m ahead -> points.
std::uint32_t run_stereo() {
  v2xloc::StereoCalibration calib;
  calib.fx = calib.fy = 40.0;
  calib.cx = 16.0;
  calib.cy = 12.0;
  calib.baseline = 0.12;
  const float d = static_cast<float>(calib.fx * calib.baseline / 8.0);
  for (std::size_t i = 0; i < kStereoWidth * kStereoHeight; ++i) {
    g_disparity[i] = d;
    g_disparity_fixed[i] = static_cast<std::uint16_t>(d * 16.0f);
  }
  v2xloc::StereoParams params;
  params.min_disparity = 0.1;
  const std::span<v2xloc::Vec3f> points(g_stereo_points, kStereoWidth * kStereoHeight);
  const std::span<float> sigma(g_stereo_sigma, kStereoWidth * kStereoHeight);
  const v2xloc::StereoCloudResult a = v2xloc::stereo_to_cloud(
      std::span<const float>(g_disparity, kStereoWidth * kStereoHeight), kStereoWidth,
      kStereoHeight, calib, params, points, sigma);
  const v2xloc::StereoCloudResult b = v2xloc::stereo_to_cloud(
      std::span<const std::uint16_t>(g_disparity_fixed, kStereoWidth * kStereoHeight), 1.0 / 16.0,
      kStereoWidth, kStereoHeight, calib, params, points, sigma);
  return a.points_out + b.points_out;
}

// EKF: vehicle signals, GNSS, odometry and a registration fix (with its covariance).
v2xloc::EkfState run_ekf(const v2xloc::Vec3d& gnss_enu, const v2xloc::OdometryResult& odometry,
                         const v2xloc::RegistrationResult& registration) {
  v2xloc::EkfState initial;
  initial.speed = 5.0;
  g_ekf.initialize(0.0, initial, v2xloc::EkfCovariance::Identity());
  std::uint32_t status = static_cast<std::uint32_t>(g_ekf.on_vehicle_signals(0.05, 5.0, 0.01));
  status |= static_cast<std::uint32_t>(g_ekf.predict_to(0.1)) << 4;
  status |= static_cast<std::uint32_t>(g_ekf.on_gnss(0.1, gnss_enu, 2.0, 4.0)) << 8;
  status |= static_cast<std::uint32_t>(g_ekf.on_odometry(0.1, 0.1, odometry.delta)) << 12;
  const v2xloc::Pose3d world_T_body(registration.transform);
  const v2xloc::PoseCovariance cov = v2xloc::registration_covariance(
      registration.information, registration.inlier_rmse, world_T_body);
  status |= static_cast<std::uint32_t>(g_ekf.on_registration(0.1, world_T_body, cov)) << 16;
  // A late wheel-speed sample: rolls back to the snapshot and replays.
  status |= static_cast<std::uint32_t>(g_ekf.on_vehicle_signals(0.08, 5.1, 0.01)) << 20;
  g_localization_status = status;
  return g_ekf.state();
}

// Start-up revision: a frame output before the filter, then the filter's first pose carries it
// back through the odometry; and the road height a pre-filter output stands on.
std::uint32_t run_backfill(const v2xloc::Mat4d& filter_pose, const v2xloc::OdometryResult& odometry,
                           std::span<const v2xloc::Vec3f> map) {
  g_backfill.reset();
  v2xloc::BackfillSample sample;
  sample.odometry_ok = true;
  g_backfill.push(sample);  // frame 0: unanchored, at the identity
  sample.frame = 1;
  sample.odom_T_body = odometry.pose.matrix();
  sample.world_T_body = filter_pose;
  sample.anchored = true;
  std::uint32_t revised = g_backfill.push(sample);
  double road = 0.0;
  revised += v2xloc::road_height_near(map, v2xloc::Vec3d(0.0, 0.0, 50.0), 30.0, road) ? 2u : 0u;
  g_sink = road;
  return revised;
}

}  // namespace

int main() {
  make_scene();
  const std::span<const v2xloc::Vec3f> source(g_source, kScenePoints);
  const std::span<const v2xloc::Vec3f> target(g_target, kScenePoints);

  // Global pipeline: downsample, k-d trees, normals, FPFH, correspondences, RANSAC, ICP.
  v2xloc::RegisterCloudsParams params;
  params.voxel_size = 0.2f;
  const v2xloc::RegisterCloudsResult global =
      v2xloc::register_clouds(source, target, params, v2xloc::Mat4d::Identity(), g_workspace);

  // ICP-only refinement (point-to-point with a robust kernel) from the global result.
  params.mode = v2xloc::RegistrationMode::kIcpOnly;
  params.icp.method = v2xloc::IcpMethod::kPointToPoint;
  params.icp.kernel.type = v2xloc::RobustKernelType::kTukey;
  const v2xloc::RegisterCloudsResult fine = v2xloc::register_clouds(
      source, target, params, global.registration.transform, g_workspace);

  v2xloc::Mat4d kabsch;
  const v2xloc::RegistrationStatus ks =
      v2xloc::kabsch_fit(source.first(64), target.first(64), {}, kabsch);

  g_status = static_cast<std::uint32_t>(global.registration.status) |
             (static_cast<std::uint32_t>(fine.registration.status) << 8) |
             (static_cast<std::uint32_t>(ks) << 16);
  g_sink = fine.registration.transform(0, 3) + kabsch(1, 3) + global.registration.fitness;

  // Localization stages on the same scene.
  const std::uint32_t map_status = fuse_map(target, source, fine.registration.transform);
  const v2xloc::OdometryResult odometry = run_odometry(target, source);
  const std::uint32_t gate_valid = run_gates(fine.registration);
  double geodesy_error = 0.0;
  const v2xloc::Vec3d gnss_enu = gnss_fix_enu(geodesy_error);
  const std::uint32_t stereo_points = run_stereo();
  const v2xloc::EkfState state = run_ekf(gnss_enu, odometry, fine.registration);
  const std::uint32_t revised = run_backfill(state.pose().matrix(), odometry, target);
  g_sink = state.pos_x + state.yaw + geodesy_error + odometry.pose.matrix()(0, 3) +
           static_cast<double>(map_status ^ gate_valid ^ stereo_points ^ revised);
  for (;;) {
  }
}
