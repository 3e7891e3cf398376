// Spinning multi-beam LiDAR. One sweep takes 1/rate seconds; the azimuth columns are fired in
// sequence and each column uses the carrier's pose at its firing time, so a scan taken while
// driving is distorted by the motion exactly as a real sweep is (deskewing undoes it with the
// per-point times). Points are expressed in the sensor frame at their own firing time.
#pragma once

#include "host_sim/common/rng.hpp"
#include "host_sim/world/world.hpp"

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace v2xloc::sim {

struct LidarConfig {
  std::string name = "lidar";
  int beams = 64;
  double elevation_max_deg = 2.0;     // top beam
  double elevation_min_deg = -25.0;   // bottom beam (beams evenly spaced in between)
  int azimuth_steps = 1024;           // columns per sweep
  double rate_hz = 10.0;              // sweeps per second
  double min_range = 0.5;             // m
  double max_range = 100.0;           // m
  double range_sigma = 0.02;          // m, Gaussian range noise
  double dropout = 0.01;              // probability a return is lost
  double intensity_sigma = 0.02;      // additive intensity noise (intensity in [0, 1])
  // Sensor pose in the carrier's body frame (x forward, y left, z up; body origin on the ground).
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();

  double elevation_deg(int beam) const;  // beam 0 = top
  double azimuth_rad(int column) const;  // column 0 starts behind the sensor, counter-clockwise
};

struct LidarPoint {
  Eigen::Vector3f p;     // sensor frame at the firing time, metres
  float intensity = 0;   // [0, 1]: reflectivity * cos(incidence) + noise
  float t = 0;           // seconds since the sweep start (the scan stamp)
  std::uint16_t ring = 0;
  std::uint16_t column = 0;
};

struct LidarScan {
  double stamp = 0.0;            // sweep start time [s]
  std::vector<LidarPoint> points;
  std::size_t rays = 0;          // rays cast
  std::size_t dropped = 0;       // returns lost to dropout
};

using BodyPoseFn = std::function<Eigen::Isometry3d(double t)>;

// Renders one sweep starting at `t0`. `body_pose(t)` is the carrier's body pose in ENU (static
// sensors: a constant). `exclude_body`: the world's dynamic body index of the carrier (-1: none).
void render_lidar_sweep(const World& world, const LidarConfig& cfg, const BodyPoseFn& body_pose, double t0,
                        int exclude_body, Rng& rng, LidarScan& out);

// Sensor presets used by the scenarios (quick = reduced resolution for CI).
LidarConfig ego_lidar_config(bool quick);
LidarConfig infra_lidar_config(bool quick);  // mount set by the caller (surveyed pose)
LidarConfig agent_lidar_config(bool quick);

}  // namespace v2xloc::sim
