#include "v2xloc/algo/localization/scan_preparation.hpp"

#include <cmath>

#include "v2xloc/algo/core/finite.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/deskew.hpp"

namespace v2xloc {
namespace {

Vec3f transform_point(const Mat4d& T, const Vec3f& p) {
  const Vec3d q = T.topLeftCorner<3, 3>() * p.cast<double>() + T.topRightCorner<3, 1>();
  return q.cast<float>();
}

}  // namespace

void ScanPreparation::configure(const LocalizerParams& params) {
  params_ = params;
  have_vehicle_delta_ = false;
  stereo_down_.clear();
}

void ScanPreparation::filter(const EgoScanInput& in, std::uint32_t& dropped) {
  filtered_.clear();
  times_.clear();
  const bool has_times = in.point_times.size() == in.points.size() && !in.points.empty();
  const float min2 = params_.min_range * params_.min_range;
  const float max2 = params_.max_range * params_.max_range;
  for (std::size_t i = 0; i < in.points.size(); ++i) {
    const Vec3f& p = in.points[i];
    const float r2 = p.squaredNorm();
    if (!is_finite_point(p) || r2 < min2 || r2 > max2 || (has_times && !std::isfinite(in.point_times[i]))) {
      ++dropped;
      continue;
    }
    if (!filtered_.push_back(p)) {
      ++dropped;
      continue;
    }
    if (has_times) times_.push_back(in.point_times[i]);
  }
}

// Deskewed with the constant-velocity sensor motion of the latest wheel speed and yaw rate
// (KISS-ICP's model). Raw vehicle signals, not the EKF's or the odometry's estimates: the
// deskewed scan feeds both, and a deskew driven by what it feeds is a feedback loop.
void ScanPreparation::prepare(const EgoScanInput& in, const VehicleMotion& vehicle, std::uint32_t& dropped) {
  stereo_down_.clear();
  std::uint32_t filtered_out = 0;
  filter(in, filtered_out);
  dropped += filtered_out;
  const bool has_times = in.point_times.size() == in.points.size() && !in.points.empty();
  deskewed_count_ = filtered_.size();
  have_vehicle_delta_ = vehicle.valid && params_.use_vehicle_signals;
  if (params_.deskew && has_times && have_vehicle_delta_) {
    Vec6d xi = Vec6d::Zero();
    xi(0) = vehicle.speed * params_.frame_period;
    xi(5) = vehicle.yaw_rate * params_.frame_period;
    const Mat4d& body_T_lidar = in.body_T_lidar.matrix();
    const Mat4d delta = se3_inverse(body_T_lidar) * se3_exp(xi) * body_T_lidar;
    DeskewParams dp;
    dp.reference_time = 0.0;
    dp.delta_duration = params_.frame_period;
    const DeskewResult r = deskew(filtered_.span(), times_.span(), delta, dp,
                                  std::span<Vec3f>(deskewed_, config::kMaxScanPoints));
    if (r.status == DeskewStatus::kOk) {
      deskewed_count_ = r.points_out;
      return;
    }
  }
  for (std::size_t i = 0; i < filtered_.size(); ++i) deskewed_[i] = filtered_[i];
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
  voxel_.run(std::span<const Vec3f>(stereo_points_, r.points_out), params_.stereo_voxel, stereo_down_);
}

void ScanPreparation::downsample_for_registration(const Mat4d& body_T_lidar) {
  body_.clear();
  for (std::size_t i = 0; i < deskewed_count_; ++i) body_.push_back(transform_point(body_T_lidar, deskewed_[i]));
  voxel_.run(body_.span(), params_.registration_voxel, down_);
  search_.clear();
  const std::size_t want = params_.search_points < config::kMaxSearchPoints ? params_.search_points
                                                                             : config::kMaxSearchPoints;
  const std::size_t n = down_.size();
  const std::size_t stride = want > 0 && n > want ? (n + want - 1) / want : 1;
  for (std::size_t i = 0; i < n; i += stride) search_.push_back(down_[i]);
}

}  // namespace v2xloc
