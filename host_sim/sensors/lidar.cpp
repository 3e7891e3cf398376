#include "host_sim/sensors/lidar.hpp"

#include <algorithm>
#include <cmath>

namespace v2xloc::sim {

double LidarConfig::elevation_deg(int beam) const {
  if (beams <= 1) return elevation_max_deg;
  return elevation_max_deg + (elevation_min_deg - elevation_max_deg) * beam / (beams - 1);
}

double LidarConfig::azimuth_rad(int column) const {
  return -M_PI + 2.0 * M_PI * (column + 0.5) / azimuth_steps;
}

void render_lidar_sweep(const World& world, const LidarConfig& cfg, const BodyPoseFn& body_pose, double t0,
                        int exclude_body, Rng& rng, LidarScan& out) {
  out.stamp = t0;
  out.points.clear();
  out.points.reserve(static_cast<std::size_t>(cfg.beams) * static_cast<std::size_t>(cfg.azimuth_steps));
  out.rays = 0;
  out.dropped = 0;
  // Beam directions in the sensor frame, by (column, beam).
  std::vector<double> cos_el(static_cast<std::size_t>(cfg.beams)), sin_el(static_cast<std::size_t>(cfg.beams));
  for (int b = 0; b < cfg.beams; ++b) {
    const double el = cfg.elevation_deg(b) * M_PI / 180.0;
    cos_el[static_cast<std::size_t>(b)] = std::cos(el);
    sin_el[static_cast<std::size_t>(b)] = std::sin(el);
  }
  const double sweep = 1.0 / cfg.rate_hz;
  for (int c = 0; c < cfg.azimuth_steps; ++c) {
    // All beams of a column fire together (as on a Velodyne/Ouster column); the column time is
    // its share of the sweep.
    const double dt = sweep * c / cfg.azimuth_steps;
    const double t = t0 + dt;
    const Eigen::Isometry3d sensor = body_pose(t) * cfg.mount;
    const DynamicSnapshot snap = world.snapshot(t);
    const double az = cfg.azimuth_rad(c);
    const double ca = std::cos(az), sa = std::sin(az);
    for (int b = 0; b < cfg.beams; ++b) {
      const Eigen::Vector3d d_sensor(cos_el[static_cast<std::size_t>(b)] * ca, cos_el[static_cast<std::size_t>(b)] * sa,
                                     sin_el[static_cast<std::size_t>(b)]);
      const Eigen::Vector3d d_world = sensor.linear() * d_sensor;
      ++out.rays;
      RayHit hit;
      // Noise draws happen for every ray in a fixed order so the stream does not depend on hits.
      const double noise = rng.gaussian(cfg.range_sigma);
      const double inten_noise = rng.gaussian(cfg.intensity_sigma);
      const bool lost = rng.bernoulli(cfg.dropout);
      if (!world.cast(sensor.translation(), d_world, cfg.max_range, hit, snap, exclude_body)) continue;
      if (hit.range < cfg.min_range) continue;
      if (lost) {
        ++out.dropped;
        continue;
      }
      const double r = hit.range + noise;
      if (r <= cfg.min_range || r > cfg.max_range) continue;
      // Lambertian return: reflectivity * cos(incidence).
      const double cos_inc = std::abs(hit.normal.dot(d_world));
      const double inten = std::clamp(material_reflectivity(hit.material) * cos_inc + inten_noise, 0.0, 1.0);
      LidarPoint pt;
      pt.p = (r * d_sensor).cast<float>();
      pt.intensity = static_cast<float>(inten);
      pt.t = static_cast<float>(dt);
      pt.ring = static_cast<std::uint16_t>(b);
      pt.column = static_cast<std::uint16_t>(c);
      out.points.push_back(pt);
    }
  }
}

LidarConfig ego_lidar_config(bool quick) {
  LidarConfig c;
  c.name = "ego_lidar";
  c.beams = quick ? 16 : 64;
  c.elevation_max_deg = 2.0;
  c.elevation_min_deg = -25.0;
  c.azimuth_steps = quick ? 256 : 1024;
  c.mount = Eigen::Isometry3d::Identity();
  c.mount.translation() = Eigen::Vector3d(0.0, 0.0, 1.9);
  return c;
}

LidarConfig infra_lidar_config(bool quick) {
  LidarConfig c;
  c.name = "infra_lidar";
  c.beams = quick ? 8 : 32;
  c.elevation_max_deg = 10.0;
  c.elevation_min_deg = -30.0;
  c.azimuth_steps = quick ? 128 : 512;
  return c;
}

LidarConfig agent_lidar_config(bool quick) {
  LidarConfig c;
  c.name = "agent_lidar";
  c.beams = quick ? 8 : 32;
  c.elevation_max_deg = 10.0;
  c.elevation_min_deg = -30.0;
  c.azimuth_steps = quick ? 128 : 512;
  c.mount = Eigen::Isometry3d::Identity();
  c.mount.translation() = Eigen::Vector3d(0.0, 0.0, 1.8);
  return c;
}

}  // namespace v2xloc::sim
