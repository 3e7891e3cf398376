#include "v2xloc/algo/localization/odometry.hpp"

#include "v2xloc/algo/registration/normals.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/core/spatial_hash.hpp"

namespace v2xloc {

namespace {
constexpr auto kMaxProbes = static_cast<std::uint32_t>(config::kVoxelMaxProbes);

Vec3d transform(const Mat4d& T, const Vec3f& p) {
  return T.topLeftCorner<3, 3>() * p.cast<double>() + T.topRightCorner<3, 1>();
}
}  // namespace

LidarOdometry::LidarOdometry(const OdometryParams& params) { configure(params); }

void LidarOdometry::configure(const OdometryParams& params) {
  params_ = params;
  if (params_.max_points_per_voxel > config::kOdometryMaxPointsPerVoxel)
    params_.max_points_per_voxel = static_cast<std::uint32_t>(config::kOdometryMaxPointsPerVoxel);
  if (params_.max_points_per_voxel == 0) params_.max_points_per_voxel = 1;
  if (params_.max_iterations > config::kOdometryMaxIterations)
    params_.max_iterations = config::kOdometryMaxIterations;
  reset();
}

void LidarOdometry::reset(const Mat4d& initial) {
  for (std::size_t i = 0; i < num_voxels_; ++i) slots_[voxels_[active_][i].slot] = 0;
  pose_ = initial;
  delta_ = Mat4d::Identity();
  last_deviation_ = Mat4d::Identity();
  first_frame_ = true;
  deviation_sse_ = 0.0;
  deviation_samples_ = 0;
  map_points_ = 0;
  num_voxels_ = 0;
}

bool LidarOdometry::voxel_key(const Vec3d& p, std::int32_t key[3]) const {
  for (int i = 0; i < 3; ++i) {
    const double k = std::floor(p(i) / params_.voxel_size);
    if (!(k > -1073741824.0 && k < 1073741824.0)) return false;
    key[i] = static_cast<std::int32_t>(k);
  }
  return true;
}

std::uint32_t LidarOdometry::find_voxel(const std::int32_t key[3]) const {
  std::uint32_t found = kNone;
  linear_probe(spatial_hash(key), kSlots, kMaxProbes, [&](std::size_t slot) {
    const std::uint32_t v = slots_[slot];
    if (v == 0) return true;
    const Voxel& vx = voxels_[active_][v - 1];
    if (vx.key[0] == key[0] && vx.key[1] == key[1] && vx.key[2] == key[2]) {
      found = v - 1;
      return true;
    }
    return false;
  });
  return found;
}

std::uint32_t LidarOdometry::insert_voxel(const std::int32_t key[3]) {
  if (num_voxels_ == kMaxPoints) return kNone;
  const ProbeResult probe = linear_probe(spatial_hash(key), kSlots, kMaxProbes,
                                         [&](std::size_t slot) { return slots_[slot] == 0; });
  if (!probe.stopped) return kNone;
  Voxel& vx = voxels_[active_][num_voxels_];
  vx.key[0] = key[0];
  vx.key[1] = key[1];
  vx.key[2] = key[2];
  vx.begin = 0;
  vx.count = 0;
  vx.pending = 0;
  vx.slot = static_cast<std::uint32_t>(probe.slot);
  slots_[probe.slot] = static_cast<std::uint32_t>(++num_voxels_);
  return static_cast<std::uint32_t>(num_voxels_ - 1);
}

bool LidarOdometry::nearest(const Vec3d& p, double max_d2, Vec3d& q, double& d2) const {
  std::int32_t key[3];
  if (!voxel_key(p, key)) return false;
  bool found = false;
  d2 = max_d2;
  const Vec3f* pts = map_[active_];
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dz = -1; dz <= 1; ++dz) {
        const std::int32_t k[3] = {key[0] + dx, key[1] + dy, key[2] + dz};
        const std::uint32_t v = find_voxel(k);
        if (v == kNone) continue;
        const Voxel& vx = voxels_[active_][v];
        for (std::uint32_t i = 0; i < vx.count; ++i) {
          const Vec3d m = pts[vx.begin + i].cast<double>();
          const double d = (m - p).squaredNorm();
          if (d < d2) {
            d2 = d;
            q = m;
            found = true;
          }
        }
      }
    }
  }
  return found;
}

double LidarOdometry::model_sigma() const {
  if (deviation_samples_ == 0) return params_.initial_threshold;
  return std::sqrt(deviation_sse_ / static_cast<double>(deviation_samples_));
}

OdometryResult LidarOdometry::register_frame(std::span<const Vec3f> scan, const Mat4d* predicted_delta) {
  OdometryResult r;
  // Range filter (also drops NaN / Inf).
  in_range_.clear();
  const double min2 = params_.min_range * params_.min_range;
  const double max2 = params_.max_range * params_.max_range;
  for (const Vec3f& p : scan) {
    const double d2 = p.cast<double>().squaredNorm();
    if (!(d2 >= min2 && d2 <= max2)) {
      ++r.points_dropped_range;
      continue;
    }
    if (!in_range_.push_back(p)) ++r.points_dropped_capacity;
  }
  // Double voxelisation (KISS-ICP III-B): 0.5 v for the map, 1.5 v for registration.
  frame_fine_.clear();
  frame_coarse_.clear();
  const VoxelDownsampleResult fine = downsample_.run(
      in_range_.span(), static_cast<float>(0.5 * params_.voxel_size), frame_fine_);
  const VoxelDownsampleResult coarse = downsample_.run(
      frame_fine_.span(), static_cast<float>(1.5 * params_.voxel_size), frame_coarse_);
  r.points_dropped_capacity += fine.output_overflow + fine.hash_overflow + fine.range_overflow +
                               coarse.output_overflow + coarse.hash_overflow +
                               coarse.range_overflow;
  r.source_points = static_cast<std::uint32_t>(frame_coarse_.size());

  const bool use_given = predicted_delta != nullptr && predicted_delta->allFinite();
  const Mat4d prediction = pose_ * (use_given ? *predicted_delta : delta_);
  if (frame_coarse_.empty()) {
    r.status = OdometryStatus::kEmptyScan;
    pose_ = prediction;
    r.pose = pose_;
    r.delta = delta_;
    r.map_points = static_cast<std::uint32_t>(map_points_);
    r.map_voxels = static_cast<std::uint32_t>(num_voxels_);
    return r;
  }
  if (first_frame_) {
    first_frame_ = false;
    update_map(pose_, r);
    r.status = OdometryStatus::kFirstFrame;
    r.pose = pose_;
    r.map_points = static_cast<std::uint32_t>(map_points_);
    r.map_voxels = static_cast<std::uint32_t>(num_voxels_);
    return r;
  }

  // Adaptive threshold from the last model deviation (eqs. 4-6).
  {
    const Vec3d w = so3_log(last_deviation_.topLeftCorner<3, 3>());
    const double theta = std::sqrt(w.squaredNorm());
    const double dev = 2.0 * params_.max_range * det::sin(0.5 * theta) +
                       std::sqrt(last_deviation_.topRightCorner<3, 1>().squaredNorm());
    if (dev > params_.min_motion) {  // KISS-ICP samples only deviations above min_motion
      deviation_sse_ += dev * dev;
      ++deviation_samples_;
    }
  }
  const double sigma = model_sigma();
  const double tau = 3.0 * sigma;
  const double kappa = sigma / 3.0;
  r.sigma = sigma;
  r.threshold = tau;

  // Source normals for the point-to-plane residual: PCA over the fine frame, each coarse point
  // takes the normal of its nearest fine point.
  if (params_.point_to_plane) {
    fine_tree_.build(frame_fine_.span());
    NormalParams np;
    np.radius = static_cast<float>(params_.normal_radius);
    np.orient_to_viewpoint = false;  // the residual is squared: the sign does not matter
    // Only the fine points some coarse point takes its normal from (about one in three) need
    // one: computed on first use, each exactly as the whole-frame pass would.
    for (std::size_t i = 0; i < frame_fine_.size(); ++i) fine_has_normal_[i] = 0;
    const std::span<Vec3f> fine_normals(fine_normals_, frame_fine_.size());
    for (std::size_t i = 0; i < frame_coarse_.size(); ++i) {
      Neighbor nb{0, 0.0f};
      const KdQueryResult q = fine_tree_.tree.nearest(frame_coarse_[i], nb);
      if (q.count > 0 && fine_has_normal_[nb.index] == 0) {
        estimate_normals_range(fine_tree_.tree, np, nb.index, 1, fine_normals);
        fine_has_normal_[nb.index] = 1;
      }
      coarse_normals_[i] = q.count > 0 ? fine_normals_[nb.index] : Vec3f::Zero();
    }
  }

  // Gauss-Newton with a Geman-McClure kernel, left-multiplied twist (rho, omega).
  Mat4d T = prediction;
  r.status = OdometryStatus::kOk;
  for (std::uint32_t it = 0; it < params_.max_iterations; ++it) {
    Mat6d H = Mat6d::Zero();
    Vec6d b = Vec6d::Zero();
    double sse = 0.0;
    std::uint32_t matches = 0;
    const Mat3d R = T.topLeftCorner<3, 3>();
    for (std::size_t i = 0; i < frame_coarse_.size(); ++i) {
      const Vec3d p = transform(T, frame_coarse_[i]);
      Vec3d q;
      double d2;
      if (!nearest(p, tau * tau, q, d2)) continue;
      const Vec3d res = p - q;
      const double k2 = kappa * kappa;
      Eigen::Matrix<double, 3, 6> J;
      J.leftCols<3>() = Mat3d::Identity();
      J.rightCols<3>() = -skew(p);
      if (params_.point_to_plane) {
        const Vec3d n = R * coarse_normals_[i].cast<double>();
        if (n.squaredNorm() < 0.5) continue;  // no normal (isolated point)
        const double e = n.dot(res);
        const double denom = k2 + e * e;
        const double w = k2 / (denom * denom) * k2;
        const Eigen::Matrix<double, 1, 6> Jn = n.transpose() * J;
        H += w * (Jn.transpose() * Jn);
        b += w * (Jn.transpose() * e);
        sse += e * e;
      } else {
        const double denom = k2 + d2;
        const double w = k2 / (denom * denom) * k2;  // normalised so w(0) = 1
        H += w * (J.transpose() * J);
        b += w * (J.transpose() * res);
        sse += d2;
      }
      ++matches;
    }
    r.iterations = it + 1;
    r.correspondences = matches;
    r.rmse = matches > 0 ? std::sqrt(sse / matches) : 0.0;
    if (matches < 6) {
      r.status = OdometryStatus::kNoCorrespondences;
      break;
    }
    const Eigen::LDLT<Mat6d> ldlt(H);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
      r.status = OdometryStatus::kDegenerate;
      break;
    }
    const Vec6d dx = -ldlt.solve(b);
    if (!dx.allFinite()) {
      r.status = OdometryStatus::kDegenerate;
      break;
    }
    T = se3_exp(dx) * T;
    if (std::sqrt(dx.squaredNorm()) < params_.convergence) {
      r.converged = true;
      break;
    }
  }
  T.topLeftCorner<3, 3>() = orthonormalize(T.topLeftCorner<3, 3>());
  if (r.status == OdometryStatus::kNoCorrespondences) T = prediction;

  last_deviation_ = se3_inverse(prediction) * T;
  delta_ = se3_inverse(pose_) * T;
  pose_ = T;
  update_map(pose_, r);
  r.pose = pose_;
  r.delta = delta_;
  r.map_points = static_cast<std::uint32_t>(map_points_);
  r.map_voxels = static_cast<std::uint32_t>(num_voxels_);
  return r;
}

void LidarOdometry::update_map(const Mat4d& pose, OdometryResult& r) {
  const std::uint32_t max_per_voxel = params_.max_points_per_voxel;
  // 1. Assign each new point to a voxel (existing or new), bounded by the per-voxel and total
  //    capacities.
  std::size_t total = map_points_;
  for (std::size_t i = 0; i < frame_fine_.size(); ++i) {
    fine_voxel_[i] = kNone;
    const Vec3d p = transform(pose, frame_fine_[i]);
    std::int32_t key[3];
    if (!voxel_key(p, key)) {
      ++r.points_dropped_capacity;
      continue;
    }
    std::uint32_t v = find_voxel(key);
    if (v == kNone) v = insert_voxel(key);
    if (v == kNone) {
      ++r.points_dropped_capacity;
      continue;
    }
    Voxel& vx = voxels_[active_][v];
    if (vx.count + vx.pending >= max_per_voxel) continue;  // voxel full: normal, not a drop
    if (total == kMaxPoints) {
      ++r.points_dropped_capacity;
      continue;
    }
    ++vx.pending;
    ++total;
    fine_voxel_[i] = v;
  }
  // 2. Compact into the other buffer, evicting voxels whose centre is beyond max_range.
  const Vec3d origin = pose.topRightCorner<3, 1>();
  const double r2 = params_.max_range * params_.max_range;
  const int next = 1 - active_;
  std::uint32_t cursor = 0;
  std::size_t kept = 0;
  for (std::size_t v = 0; v < num_voxels_; ++v) {
    Voxel& vx = voxels_[active_][v];
    slots_[vx.slot] = 0;
    const Vec3d centre((vx.key[0] + 0.5) * params_.voxel_size,
                       (vx.key[1] + 0.5) * params_.voxel_size,
                       (vx.key[2] + 0.5) * params_.voxel_size);
    const bool evict = (centre - origin).squaredNorm() > r2 || vx.count + vx.pending == 0;
    if (evict) {
      ++r.voxels_evicted;
      vx.pending = kNone;  // marks the voxel dropped for step 3
      continue;
    }
    Voxel& out = voxels_[next][kept];
    out = vx;
    out.begin = cursor;
    for (std::uint32_t i = 0; i < vx.count; ++i) map_[next][cursor + i] = map_[active_][vx.begin + i];
    cursor += vx.count + vx.pending;
    out.pending = 0;
    vx.begin = static_cast<std::uint32_t>(kept);  // old index -> new index, for step 3
    ++kept;
  }
  // 3. Append the new points in input order.
  for (std::size_t i = 0; i < frame_fine_.size(); ++i) {
    const std::uint32_t v = fine_voxel_[i];
    if (v == kNone || voxels_[active_][v].pending == kNone) continue;
    Voxel& out = voxels_[next][voxels_[active_][v].begin];
    map_[next][out.begin + out.count] = transform(pose, frame_fine_[i]).cast<float>();
    ++out.count;
  }
  active_ = next;
  num_voxels_ = kept;
  map_points_ = cursor;
  rebuild_index();
}

void LidarOdometry::rebuild_index() {
  for (std::size_t v = 0; v < num_voxels_; ++v) {
    Voxel& vx = voxels_[active_][v];
    // The table holds at most kMaxPoints <= kSlots voxels; probing beyond the cap would only
    // happen for a pathological key set and then the voxel is unreachable (still counted in map).
    const ProbeResult probe = linear_probe(spatial_hash(vx.key), kSlots, kMaxProbes,
                                           [&](std::size_t slot) { return slots_[slot] == 0; });
    if (probe.stopped) {
      slots_[probe.slot] = static_cast<std::uint32_t>(v + 1);
      vx.slot = static_cast<std::uint32_t>(probe.slot);
    } else {
      vx.slot = 0;  // unreachable voxel; slot 0 cleared harmlessly
    }
  }
}

}  // namespace v2xloc
