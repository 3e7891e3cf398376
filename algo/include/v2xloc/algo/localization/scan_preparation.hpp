// The ego frame's clouds, ready for the stages after it: the LiDAR sweep read once into
// registration voxels and deskewed (sensor frame, for the odometry: scan_ingest.hpp), the same
// points in the body frame (the registration to the map) with the tracking ICP's and the pose
// search's subsamples, and the stereo cloud. Owns the scan buffers.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"
#include "v2xloc/algo/localization/scan_ingest.hpp"
#include "v2xloc/algo/registration/voxel_downsample.hpp"

namespace v2xloc {

class ScanPreparation {
 public:
  // use_vehicle_signals: deskew and the odometry's prediction take the wheel speed and yaw rate.
  void configure(const ScanPreparationParams& params, bool use_vehicle_signals);

  // Finite points within [min_range, max_range] (the rest counted in dropped), deskewed with the
  // vehicle signals' motion over one frame; the stereo cloud is cleared.
  // dropped / coarsened: running counts (returns dropped; sweeps read again with a coarser voxel).
  // Returns the passes the ingest read the sweep in (1, or more when it was read again coarser).
  std::uint32_t prepare(const EgoScanInput& in, const VehicleMotion& vehicle, std::uint32_t& dropped,
                        std::uint32_t& coarsened);
  // Disparity -> body-frame points with depth sigmas, the noisy far ones dropped, downsampled.
  void prepare_stereo(const StereoInput& stereo);
  // The deskewed scan in the body frame, downsampled, and every k-th point of it for the search.
  void downsample_for_registration(const Mat4d& body_T_lidar);

  // The vehicle signals gave this frame's sensor motion (deskew and odometry prediction use it).
  bool has_vehicle_motion() const { return have_vehicle_delta_; }
  // The voxelised, deskewed sweep in the LiDAR frame (the odometry's 0.5 v frame).
  std::span<const Vec3f> deskewed() const { return ingest_.points(); }
  std::span<const Vec3f> registration_scan() const { return down_.span(); }
  std::span<const Vec3f> tracking_scan() const { return tracking_.span(); }
  std::span<const Vec3f> search_scan() const { return search_.span(); }
  std::span<const Vec3f> stereo_cloud() const { return stereo_down_.span(); }
  double stereo_mean_sigma() const { return stereo_mean_sigma_; }  // [m] depth sigma

 private:
  static void subsample(std::span<const Vec3f> in, std::size_t want, BoundedVector<Vec3f>& out);

  ScanPreparationParams params_{};
  bool use_vehicle_signals_ = true;
  bool have_vehicle_delta_ = false;
  ScanIngest ingest_{};
  FixedVector<Vec3f, config::kMaxDownsampledPoints> down_;
  FixedVector<Vec3f, config::kMaxDownsampledPoints> tracking_;
  FixedVector<Vec3f, config::kMaxSearchPoints> search_;
  // The stereo cloud's voxels (the sweep's are the ingest's): twice the slots of the voxels it holds.
  VoxelDownsampleStorage<2 * config::kMaxDownsampledPoints, config::kMaxDownsampledPoints> stereo_voxel_;
  Vec3f stereo_points_[config::kMaxStereoPoints];
  float stereo_sigma_[config::kMaxStereoPoints];
  FixedVector<Vec3f, config::kMaxDownsampledPoints> stereo_down_;
  double stereo_mean_sigma_ = 0.0;
};

}  // namespace v2xloc
