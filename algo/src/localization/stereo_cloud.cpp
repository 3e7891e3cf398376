#include "v2xloc/algo/localization/stereo_cloud.hpp"

#include <cmath>

namespace v2xloc {

namespace {

bool valid_calibration(const StereoCalibration& c) {
  return c.fx > 0.0 && c.fy > 0.0 && c.baseline > 0.0 && std::isfinite(c.cx) &&
         std::isfinite(c.cy) && c.vehicle_T_camera.allFinite();
}

// Shared pixel loop; read(i) returns the disparity [px] of pixel i (NaN when invalid).
template <class Reader>
StereoCloudResult convert(Reader read, std::size_t size, std::uint32_t width,
                          std::uint32_t height, const StereoCalibration& c,
                          const StereoParams& params, std::span<Vec3f> points_out,
                          std::span<float> sigma_out) {
  StereoCloudResult r;
  if (!valid_calibration(c) || params.stride == 0 ||
      size != static_cast<std::size_t>(width) * height ||
      (!sigma_out.empty() && sigma_out.size() < points_out.size())) {
    return r;
  }
  r.status = StereoStatus::kOk;
  const double fb = c.fx * c.baseline;  // [px m]
  const Mat3d R = c.vehicle_T_camera.topLeftCorner<3, 3>();
  const Vec3d t = c.vehicle_T_camera.topRightCorner<3, 1>();
  std::size_t n = 0;
  for (std::uint32_t v = 0; v < height; v += params.stride) {
    for (std::uint32_t u = 0; u < width; u += params.stride) {
      ++r.pixels_visited;
      const double d = read(static_cast<std::size_t>(v) * width + u);
      if (!std::isfinite(d) || d == 0.0) {
        ++r.invalid;
        continue;
      }
      const double z = fb / d;
      const double sigma_z = z * z / fb * params.disparity_sigma;
      if (d < params.min_disparity || d > params.max_disparity ||
          sigma_z > params.max_depth_sigma) {
        ++r.out_of_range;
        continue;
      }
      if (n == points_out.size()) {
        ++r.capacity_dropped;
        r.status = StereoStatus::kTruncated;
        continue;
      }
      const Vec3d p_cam((u - c.cx) * z / c.fx, (v - c.cy) * z / c.fy, z);
      points_out[n] = (R * p_cam + t).cast<float>();
      if (!sigma_out.empty()) sigma_out[n] = static_cast<float>(sigma_z);
      ++n;
    }
  }
  r.points_out = static_cast<std::uint32_t>(n);
  return r;
}

}  // namespace

StereoCloudResult stereo_to_cloud(std::span<const float> disparity, std::uint32_t width,
                                  std::uint32_t height, const StereoCalibration& calibration,
                                  const StereoParams& params, std::span<Vec3f> points_out,
                                  std::span<float> depth_sigma_out) {
  return convert([&](std::size_t i) { return static_cast<double>(disparity[i]); },
                 disparity.size(), width, height, calibration, params, points_out,
                 depth_sigma_out);
}

StereoCloudResult stereo_to_cloud(std::span<const std::uint16_t> disparity, double scale,
                                  std::uint32_t width, std::uint32_t height,
                                  const StereoCalibration& calibration, const StereoParams& params,
                                  std::span<Vec3f> points_out, std::span<float> depth_sigma_out) {
  if (!(scale > 0.0) || !std::isfinite(scale)) return {};
  return convert([&](std::size_t i) { return static_cast<double>(disparity[i]) * scale; },
                 disparity.size(), width, height, calibration, params, points_out,
                 depth_sigma_out);
}

}  // namespace v2xloc
