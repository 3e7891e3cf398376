#include "host_sim/sensors/lidar.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace v2xloc::sim {
namespace {

// A closed courtyard: ground plane and four walls 20 m away; every downward or horizontal ray hits.
World courtyard() {
  World w;
  const int id = w.new_object_id();
  w.add(Primitive::box({20, -40, 0}, {21, 40, 30}, kMatBuilding, id));
  w.add(Primitive::box({-21, -40, 0}, {-20, 40, 30}, kMatBuilding, id));
  w.add(Primitive::box({-40, 20, 0}, {40, 21, 30}, kMatBuilding, id));
  w.add(Primitive::box({-40, -21, 0}, {40, -20, 30}, kMatBuilding, id));
  w.build();
  return w;
}

LidarConfig noiseless(int beams, int steps) {
  LidarConfig c;
  c.beams = beams;
  c.azimuth_steps = steps;
  c.range_sigma = 0;
  c.dropout = 0;
  c.intensity_sigma = 0;
  c.mount.translation() = Eigen::Vector3d(0, 0, 1.9);
  return c;
}

double distance_to_courtyard(const Eigen::Vector3d& p) {
  double d = std::abs(p.z());
  d = std::min(d, std::abs(std::abs(p.x()) - 20.0));
  d = std::min(d, std::abs(std::abs(p.y()) - 20.0));
  return d;
}

TEST(HostSimLidar, ScanSizeFollowsTheBeamModel) {
  const World w = courtyard();
  Rng rng(1);
  LidarScan scan;
  const LidarConfig c = noiseless(32, 360);
  render_lidar_sweep(w, c, [](double) { return Eigen::Isometry3d::Identity(); }, 0.0, -1, rng, scan);
  EXPECT_EQ(scan.rays, 32u * 360u);
  EXPECT_EQ(scan.points.size(), 32u * 360u);  // closed courtyard: every ray returns
  for (const auto& p : scan.points) {
    EXPECT_GE(p.t, 0.0f);
    EXPECT_LT(p.t, 0.1f);
    const double el = std::atan2(p.p.z(), p.p.head<2>().norm()) * 180.0 / M_PI;
    EXPECT_NEAR(el, c.elevation_deg(p.ring), 1e-4);
    const double az = std::atan2(p.p.y(), p.p.x());
    EXPECT_NEAR(std::remainder(az - c.azimuth_rad(p.column), 2 * M_PI), 0.0, 1e-5);
  }
  // With 1% dropout the count drops by ~1% (binomial, 5 sigma).
  LidarConfig d = c;
  d.dropout = 0.01;
  render_lidar_sweep(w, d, [](double) { return Eigen::Isometry3d::Identity(); }, 0.0, -1, rng, scan);
  const double n = 32.0 * 360.0;
  EXPECT_NEAR(static_cast<double>(scan.points.size()), 0.99 * n, 5.0 * std::sqrt(n * 0.01 * 0.99));
  EXPECT_EQ(scan.points.size() + scan.dropped, static_cast<std::size_t>(n));
}

TEST(HostSimLidar, RangeNoiseMatchesSigmaOnAKnownWall) {
  World w;
  w.set_ground_plane(false);
  w.add(Primitive::box({15, -100, -100}, {16, 100, 100}, kMatBuilding, w.new_object_id()));
  w.build();
  LidarConfig c = noiseless(16, 720);
  c.elevation_max_deg = 10;
  c.elevation_min_deg = -10;
  c.range_sigma = 0.02;
  c.mount = Eigen::Isometry3d::Identity();
  Rng rng(2);
  LidarScan scan;
  render_lidar_sweep(w, c, [](double) { return Eigen::Isometry3d::Identity(); }, 0.0, -1, rng, scan);
  ASSERT_GT(scan.points.size(), 1000u);
  double s = 0, s2 = 0;
  for (const auto& p : scan.points) {
    const Eigen::Vector3d d = p.p.cast<double>().normalized();
    const double true_range = 15.0 / d.x();
    const double err = p.p.cast<double>().norm() - true_range;
    EXPECT_LT(std::abs(err), 6 * 0.02);
    s += err;
    s2 += err * err;
    // Intensity falls with the incidence angle (cos law).
    EXPECT_NEAR(p.intensity, material_reflectivity(kMatBuilding) * d.x(), 1e-5);
  }
  const double n = static_cast<double>(scan.points.size());
  EXPECT_NEAR(s / n, 0.0, 0.003);
  EXPECT_NEAR(std::sqrt(s2 / n), 0.02, 0.002);
}

// Moving sweep vs static sweep: interpreting the raw points with the sweep-start pose leaves the
// motion in them; undoing the motion with the per-point times and the true trajectory puts every
// point back on the surfaces (deskew).
TEST(HostSimLidar, MovingSweepDiffersFromStaticByExactlyTheMotion) {
  const World w = courtyard();
  const LidarConfig c = noiseless(32, 512);
  auto traj = [](double t) {  // 12 m/s forward with 0.5 rad/s yaw rate
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.5 * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(12.0 * t - 3.0, 1.0, 0.0);
    return T;
  };
  const double t0 = 0.3;
  Rng rng(3);
  LidarScan moving, still;
  render_lidar_sweep(w, c, traj, t0, -1, rng, moving);
  render_lidar_sweep(w, c, [&](double) { return traj(t0); }, t0, -1, rng, still);
  ASSERT_EQ(moving.points.size(), still.points.size());
  const Eigen::Isometry3d start = traj(t0) * c.mount;
  double max_raw = 0, max_deskewed = 0, max_static = 0, max_shift = 0;
  for (std::size_t i = 0; i < moving.points.size(); ++i) {
    const auto& p = moving.points[i];
    const Eigen::Vector3d raw_world = start * p.p.cast<double>();
    const Eigen::Vector3d deskewed_world = traj(t0 + p.t) * c.mount * p.p.cast<double>();
    max_raw = std::max(max_raw, distance_to_courtyard(raw_world));
    max_deskewed = std::max(max_deskewed, distance_to_courtyard(deskewed_world));
    max_static = std::max(max_static, distance_to_courtyard(start * still.points[i].p.cast<double>()));
    // Same ray index in both sweeps; the moving one fired from a pose shifted by the motion.
    max_shift = std::max(max_shift, (traj(t0 + p.t).translation() - traj(t0).translation()).norm());
  }
  EXPECT_LT(max_deskewed, 1e-4);  // float32 storage of the points
  EXPECT_LT(max_static, 1e-4);
  EXPECT_GT(max_raw, 0.5);        // the motion (1.2 m and 2.9 deg per sweep) is in the raw scan
  EXPECT_NEAR(max_shift, 12.0 * 0.1 * 511.0 / 512.0, 0.02);
}

}  // namespace
}  // namespace v2xloc::sim
