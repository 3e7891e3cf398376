#include "host_sim/sensors/stereo.hpp"

#include <algorithm>
#include <cmath>

namespace v2xloc::sim {

StereoCalibration StereoConfig::calibration() const {
  StereoCalibration c;
  const double s = 1.0 / downsample;
  c.width = full_width / downsample;
  c.height = full_height / downsample;
  c.fx = fx * s;
  c.fy = fy * s;
  // Pixel centres: full-res pixel u covers [u, u+1); the downsampled pixel k covers
  // [k*ds, (k+1)*ds), so cx scales as (cx + 0.5) / ds - 0.5.
  c.cx = (cx + 0.5) * s - 0.5;
  c.cy = (cy + 0.5) * s - 0.5;
  c.baseline = baseline;
  Eigen::Matrix3d r;  // columns: camera x (right) = -body y, camera y (down) = -body z, camera z = body x
  r << 0, 0, 1,
      -1, 0, 0,
      0, -1, 0;
  c.camera_to_body.linear() = r;
  c.camera_to_body.translation() = left_camera_position;
  return c;
}

DisparityStats render_disparity(const World& world, const StereoConfig& cfg, const Eigen::Isometry3d& body_pose,
                                double t, int exclude_body, Rng& rng, Image16& out) {
  const StereoCalibration cal = cfg.calibration();
  out.width = cal.width;
  out.height = cal.height;
  out.pixels.assign(static_cast<std::size_t>(cal.width) * static_cast<std::size_t>(cal.height), 0);
  DisparityStats st;
  const Eigen::Isometry3d cam = body_pose * cal.camera_to_body;
  const Eigen::Vector3d right_origin = cam * Eigen::Vector3d(cal.baseline, 0, 0);
  const DynamicSnapshot snap = world.snapshot(t);
  const double fb = cal.fx * cal.baseline;
  for (int v = 0; v < cal.height; ++v) {
    for (int u = 0; u < cal.width; ++u) {
      const double noise = rng.gaussian(cfg.disparity_sigma);
      const bool fail = rng.bernoulli(cfg.random_invalid);
      const Eigen::Vector3d ray_cam((u - cal.cx) / cal.fx, (v - cal.cy) / cal.fy, 1.0);
      const Eigen::Vector3d dir = (cam.linear() * ray_cam).normalized();
      RayHit hit;
      if (!world.cast(cam.translation(), dir, cfg.max_range, hit, snap, exclude_body)) {
        ++st.sky;
        continue;
      }
      const double z = hit.range / ray_cam.norm();  // depth along the optical axis
      const double d = fb / z + noise;
      if (d < cfg.min_disparity) {
        ++st.too_far;
        continue;
      }
      if (fail) {
        ++st.random_invalid;
        continue;
      }
      if (cfg.check_occlusion) {
        const Eigen::Vector3d p = cam.translation() + hit.range * dir;
        const Eigen::Vector3d to_p = p - right_origin;
        const double dist = to_p.norm();
        RayHit h2;
        if (world.cast(right_origin, to_p / dist, dist - 0.05, h2, snap, exclude_body)) {
          ++st.occluded;
          continue;
        }
      }
      const double q = std::round(d * 256.0);
      out.pixels[static_cast<std::size_t>(v) * static_cast<std::size_t>(cal.width) + static_cast<std::size_t>(u)] =
          static_cast<std::uint16_t>(std::clamp(q, 1.0, 65535.0));
      ++st.valid;
    }
  }
  return st;
}

StereoConfig ego_stereo_config(bool quick) {
  StereoConfig c;
  c.downsample = quick ? 8 : 2;
  return c;
}

}  // namespace v2xloc::sim
