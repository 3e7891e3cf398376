// Ego stereo pair rendered as a left-camera disparity map (rectified pair, pinhole model):
// d = fx * b / z. Noise: Gaussian disparity noise (sigma ~0.3 px); invalid pixels where nothing is
// hit (sky), where the right camera cannot see the point (occlusion), below the minimum disparity,
// and at random (textureless / matching failures). Saved KITTI-style: uint16 = d * 256, 0 = invalid.
#pragma once

#include "host_sim/common/png.hpp"
#include "host_sim/common/rng.hpp"
#include "host_sim/world/world.hpp"

#include <Eigen/Geometry>

namespace v2xloc::sim {

struct StereoCalibration {
  int width = 0, height = 0;          // pixels of the rendered disparity map
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double baseline = 0.54;             // m, left -> right camera along +x of the camera frame
  // Left camera (optical frame: x right, y down, z forward) in the vehicle body frame.
  Eigen::Isometry3d camera_to_body = Eigen::Isometry3d::Identity();
};

struct StereoConfig {
  // Full-resolution camera (KITTI-like); rendered at 1/downsample of it, intrinsics scaled.
  int full_width = 1242, full_height = 375;
  double fx = 721.5, fy = 721.5, cx = 609.6, cy = 172.9;
  double baseline = 0.54;
  int downsample = 2;
  double disparity_sigma = 0.3;       // px at the rendered resolution
  double random_invalid = 0.03;       // fraction of pixels failing to match
  double min_disparity = 1.0;         // px; farther points are invalid
  double max_range = 80.0;            // m
  bool check_occlusion = true;        // cast a second ray from the right camera
  Eigen::Vector3d left_camera_position = Eigen::Vector3d(0.8, 0.27, 1.65);  // body frame

  StereoCalibration calibration() const;
};

struct DisparityStats {
  std::size_t valid = 0, sky = 0, occluded = 0, too_far = 0, random_invalid = 0;
};

// Renders the disparity map of the left camera at time t (global shutter).
DisparityStats render_disparity(const World& world, const StereoConfig& cfg, const Eigen::Isometry3d& body_pose,
                                double t, int exclude_body, Rng& rng, Image16& out);

StereoConfig ego_stereo_config(bool quick);

}  // namespace v2xloc::sim
