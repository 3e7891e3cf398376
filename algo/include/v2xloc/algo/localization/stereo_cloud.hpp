// Stereo disparity -> 3-D points with a per-point depth uncertainty, for registering the stereo
// camera like a LiDAR but weighted by its noise (issue 4, "stereo modality").
// Rectified pinhole pair (OpenCV camera frame: x right, y down, z forward):
//   z = fx b / d,  x = (u - cx) z / fx,  y = (v - cy) z / fy,
// and first-order propagation of a disparity error sigma_d gives
//   sigma_z = |dz/dd| sigma_d = z^2 / (fx b) sigma_d
// (Matthies & Shafer 1987): depth noise grows with the square of the range, which is why far
// stereo points must weigh less than LiDAR points. Points are returned in the vehicle frame.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct StereoCalibration {
  double fx = 0.0, fy = 0.0;   // [px] focal lengths of the rectified left camera
  double cx = 0.0, cy = 0.0;   // [px] principal point
  double baseline = 0.0;       // [m] distance between the optical centres
  Mat4d vehicle_T_camera = Mat4d::Identity();  // left camera pose in the vehicle frame
};

struct StereoParams {
  std::uint32_t stride = 1;        // take every stride-th pixel in u and v (subsampling)
  double min_disparity = 1.0;      // [px] below: too far / unreliable (z > fx b / 1 px)
  double max_disparity = 1e9;      // [px] above: too close / mismatched
  double disparity_sigma = 0.5;    // [px] 1-sigma matching error (sub-pixel SGM: 0.25-1 px)
  double max_depth_sigma = 1e30;   // [m] drop points noisier than this
};

enum class StereoStatus : std::uint8_t {
  kOk,
  kInvalidInput,  // bad calibration, image size mismatch, stride 0, non-positive scale
  kTruncated,     // output buffers full: remaining valid pixels dropped (counted)
};

struct StereoCloudResult {
  StereoStatus status = StereoStatus::kInvalidInput;
  std::uint32_t pixels_visited = 0;
  std::uint32_t points_out = 0;
  std::uint32_t invalid = 0;          // disparity 0, NaN or Inf (no match)
  std::uint32_t out_of_range = 0;     // outside [min, max] disparity or above max_depth_sigma
  std::uint32_t capacity_dropped = 0;
};

// disparity: row-major width x height, in pixels. points_out / depth_sigma_out: caller buffers
// (depth_sigma_out may be empty; otherwise it must be as large as points_out).
StereoCloudResult stereo_to_cloud(std::span<const float> disparity, std::uint32_t width,
                                  std::uint32_t height, const StereoCalibration& calibration,
                                  const StereoParams& params, std::span<Vec3f> points_out,
                                  std::span<float> depth_sigma_out);
// Fixed-point disparity (e.g. OpenCV SGBM's int16 x16, or 16-bit PNG x256): d = raw * scale;
// raw 0 is invalid.
StereoCloudResult stereo_to_cloud(std::span<const std::uint16_t> disparity, double scale,
                                  std::uint32_t width, std::uint32_t height,
                                  const StereoCalibration& calibration, const StereoParams& params,
                                  std::span<Vec3f> points_out, std::span<float> depth_sigma_out);

}  // namespace v2xloc
