#include "v2xloc/algo/localization/scan_preparation.hpp"

#include <cmath>

#include "v2xloc/algo/core/finite.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/deskew.hpp"
#include "v2xloc/algo/localization/scan_ingest.hpp"

namespace v2xloc {
namespace {

Vec3f transform_point(const Mat4d& T, const Vec3f& p) {
  const Vec3d q = T.topLeftCorner<3, 3>() * p.cast<double>() + T.topRightCorner<3, 1>();
  return q.cast<float>();
}

}  // namespace

void ScanPreparation::configure(const ScanPreparationParams& params, bool use_vehicle_signals) {
  params_ = params;
  use_vehicle_signals_ = use_vehicle_signals;
  have_vehicle_delta_ = false;
  stereo_down_.clear();
  ingest_.forget_steps();
}

// The sweep read once (scan_ingest.hpp): finite returns within [min_range, max_range] merged
// per registration voxel in the LiDAR frame, then deskewed with the constant-velocity sensor
// motion of the latest wheel speed and yaw rate (KISS-ICP's model). Raw vehicle signals, not the
// EKF's or the odometry's estimates: the deskewed scan feeds both, and a deskew driven by what
// it feeds is a feedback loop.
std::uint32_t ScanPreparation::prepare(const EgoScanInput& in, const VehicleMotion& vehicle, std::uint32_t& dropped,
                                       std::uint32_t& coarsened) {
  stereo_down_.clear();
  have_vehicle_delta_ = vehicle.valid && use_vehicle_signals_;
  Mat4d delta = Mat4d::Identity();
  if (have_vehicle_delta_) {
    Vec6d xi = Vec6d::Zero();
    xi(0) = vehicle.speed * params_.frame_period;
    xi(5) = vehicle.yaw_rate * params_.frame_period;
    const Mat4d& body_T_lidar = in.body_T_lidar.matrix();
    delta = se3_inverse(body_T_lidar) * se3_exp(xi) * body_T_lidar;
  }
  ScanIngestParams ip;
  ip.min_range = params_.min_range;
  ip.max_range = params_.max_range;
  ip.voxel = params_.registration_voxel;
  ip.frame_period = params_.frame_period;
  const ScanIngestResult r = ingest_.run(in.points, in.point_times, have_vehicle_delta_ ? &delta : nullptr, ip);
  dropped += r.non_finite_dropped + r.range_dropped + r.capacity_dropped;
  coarsened += r.coarsened > 0 ? 1u : 0u;
  return r.passes > 0 ? r.passes : 1u;
}

void ScanPreparation::prepare_stereo(const StereoInput& stereo) {
  StereoParams sp = params_.stereo;
  if (stereo.disparity_sigma > 0.0) sp.disparity_sigma = stereo.disparity_sigma;
  const StereoCloudResult r =
      stereo_to_cloud(stereo.disparity, stereo.scale, stereo.width, stereo.height, stereo.calibration, sp,
                      std::span<Vec3f>(stereo_points_, config::kMaxStereoPoints),
                      std::span<float>(stereo_sigma_, config::kMaxStereoPoints));
  if (r.status == StereoStatus::kInvalidInput || r.points_out == 0) return;
  double sum = 0.0;
  for (std::uint32_t i = 0; i < r.points_out; ++i) sum += stereo_sigma_[i];
  stereo_mean_sigma_ = sum / r.points_out;
  stereo_voxel_.run(std::span<const Vec3f>(stereo_points_, r.points_out), params_.stereo_voxel, stereo_down_);
}

// The ingested scan is already one point per registration voxel: moved to the body frame, with
// two even subsamples, the tracking ICP's (<= tracking_points) and the pose search's.
void ScanPreparation::downsample_for_registration(const Mat4d& body_T_lidar) {
  down_.clear();
  for (const Vec3f& p : ingest_.points()) down_.push_back(transform_point(body_T_lidar, p));
  subsample(down_.span(), params_.tracking_points, tracking_);
  subsample(down_.span(), params_.search_points < config::kMaxSearchPoints ? params_.search_points
                                                                          : config::kMaxSearchPoints,
            search_);
}

void ScanPreparation::subsample(std::span<const Vec3f> in, std::size_t want, BoundedVector<Vec3f>& out) {
  out.clear();
  const std::size_t n = in.size();
  if (want == 0) want = n;
  const std::size_t stride = n > want ? (n + want - 1) / want : 1;
  for (std::size_t i = 0; i < n; i += stride) out.push_back(in[i]);
}

}  // namespace v2xloc
