#include "v2xloc/algo/localization/odometry.hpp"

#include "v2xloc/algo/core/symmetric_eigen.hpp"

#include <cmath>
#include <cstdint>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/normal_equations.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/core/spatial_hash.hpp"

namespace v2xloc {

namespace {
constexpr auto kMaxProbes = static_cast<std::uint32_t>(config::kVoxelMaxProbes);
constexpr std::uint32_t kMaxFineCoarsenSteps = 8;  // raw-sweep path: 0.5 v x (9/8)^8 <= 1.3 v

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
  map_.configure(params_.voxel_size, params_.max_points_per_voxel);
  reset();
}

void LidarOdometry::reset(const Pose3d& initial) {
  map_.clear();
  pose_ = initial.matrix();
  delta_ = Mat4d::Identity();
  last_deviation_ = Mat4d::Identity();
  first_frame_ = true;
  deviation_sse_ = 0.0;
  deviation_samples_ = 0;
}

double LidarOdometry::model_sigma() const {
  if (deviation_samples_ == 0) return params_.initial_threshold;
  return std::sqrt(deviation_sse_ / static_cast<double>(deviation_samples_));
}

// Points within [min_range, max_range] (NaN / Inf fail the test too), drops counted.
void LidarOdometry::keep_in_range(std::span<const Vec3f> points, BoundedVector<Vec3f>& out, OdometryResult& r) const {
  out.clear();
  const double min2 = params_.min_range * params_.min_range;
  const double max2 = params_.max_range * params_.max_range;
  for (const Vec3f& p : points) {
    const double d2 = p.cast<double>().squaredNorm();
    if (!(d2 >= min2 && d2 <= max2)) {
      ++r.points_dropped_range;
      continue;
    }
    if (!out.push_back(p)) ++r.points_dropped_capacity;
  }
}

OdometryResult LidarOdometry::register_frame(std::span<const Vec3f> scan, OdometryScanBuffers& buffers,
                                             const Pose3d* predicted_delta) {
  OdometryResult r;
  // Range filter (also drops NaN / Inf).
  keep_in_range(scan, buffers.in_range, r);
  // Double voxelisation (KISS-ICP III-B): 0.5 v for the map, 1.5 v for registration. A sweep
  // with more fine voxels than the frame holds is read again with the voxel grown by 9/8, as the
  // localizer's scan ingest does: cutting the output would drop the sweep's last sectors.
  float voxel = static_cast<float>(0.5 * params_.voxel_size);
  VoxelDownsampleResult fine;
  for (std::uint32_t step = 0;; ++step, voxel *= 1.125f) {
    const bool last_try = step >= kMaxFineCoarsenSteps;
    frame_fine_.clear();
    fine = buffers.downsample.run(buffers.in_range.span(), voxel, frame_fine_, SIZE_MAX, !last_try);
    if (fine.status != VoxelStatus::kStoppedFull) break;
  }
  r.points_dropped_capacity += fine.output_overflow + fine.hash_overflow + fine.range_overflow;
  return register_fine(predicted_delta != nullptr ? &predicted_delta->matrix() : nullptr, r);
}

OdometryResult LidarOdometry::register_voxelized_frame(std::span<const Vec3f> fine, const Pose3d* predicted_delta) {
  OdometryResult r;
  keep_in_range(fine, frame_fine_, r);
  thin_fine_frame(r);
  return register_fine(predicted_delta != nullptr ? &predicted_delta->matrix() : nullptr, r);
}

// Every fine_decimation-th point, and an even subsample of at most max_fine_points (kept in
// order): the frame's set-up (coarse voxels, their normals, the map update) and its registration
// are linear in its points.
void LidarOdometry::thin_fine_frame(OdometryResult& r) {
  const std::size_t n = frame_fine_.size(), cap = params_.max_fine_points;
  std::size_t stride = params_.fine_decimation > 1 ? params_.fine_decimation : 1;
  if (cap > 0 && (n + stride - 1) / stride > cap) {
    stride = (n + cap - 1) / cap;
    r.fine_points_capped = true;
  }
  if (stride <= 1) return;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < n; i += stride) frame_fine_[kept++] = frame_fine_[i];
  frame_fine_.resize(kept);
  r.fine_points_skipped = static_cast<std::uint32_t>(n - kept);
}

OdometryResult LidarOdometry::register_fine(const Mat4d* predicted_delta, OdometryResult& r) {
  build_coarse_frame(r);
  r.source_points = static_cast<std::uint32_t>(frame_coarse_.size());
  const bool use_given = predicted_delta != nullptr && predicted_delta->allFinite();
  const Mat4d prediction = pose_ * (use_given ? *predicted_delta : delta_);
  if (frame_coarse_.empty()) {
    r.status = OdometryStatus::kEmptyScan;
    pose_ = prediction;
    return finish_frame(r);
  }
  if (first_frame_) {
    first_frame_ = false;
    map_.update(frame_fine_.span(), pose_, params_.max_range, r.points_dropped_capacity, r.voxels_evicted);
    r.status = OdometryStatus::kFirstFrame;
    return finish_frame(r);
  }
  update_threshold(r);
  Mat4d T = align(prediction, r);
  T.topLeftCorner<3, 3>() = orthonormalize(T.topLeftCorner<3, 3>());
  if (r.status == OdometryStatus::kNoCorrespondences) T = prediction;
  last_deviation_ = se3_inverse(prediction) * T;
  delta_ = se3_inverse(pose_) * T;
  pose_ = T;
  map_.update(frame_fine_.span(), pose_, params_.max_range, r.points_dropped_capacity, r.voxels_evicted);
  return finish_frame(r);
}

OdometryResult LidarOdometry::finish_frame(OdometryResult& r) const {
  r.pose = Pose3d(pose_);
  r.delta = Pose3d(delta_);
  r.map_points = static_cast<std::uint32_t>(map_.points().size());
  r.map_voxels = static_cast<std::uint32_t>(map_.voxel_count());
  return r;
}

// Adaptive threshold from the last model deviation (eqs. 4-6).
void LidarOdometry::update_threshold(OdometryResult& r) {
  const Vec3d w = so3_log(last_deviation_.topLeftCorner<3, 3>());
  const double theta = std::sqrt(w.squaredNorm());
  const double dev = 2.0 * params_.max_range * det::sin(0.5 * theta) +
                     std::sqrt(last_deviation_.topRightCorner<3, 1>().squaredNorm());
  if (dev > params_.min_motion) {  // KISS-ICP samples only deviations above min_motion
    deviation_sse_ += dev * dev;
    ++deviation_samples_;
  }
  r.sigma = model_sigma();
  r.threshold = 3.0 * r.sigma;
}

// The 1.5 v registration points: centroids of the fine points per coarse voxel (in order of
// first occurrence), each with a source normal for the point-to-plane residual: the PCA of the
// fine points in the 2 x 2 x 2 coarse voxels around it (a ~3 v box, like a 1.5 v radius), from
// moments summed while voxelising: no search structure, no neighbour queries.
void LidarOdometry::build_coarse_frame(OdometryResult& r) {
  frame_coarse_.clear();
  const double cv = 1.5 * params_.voxel_size;
  std::size_t voxels = 0;
  std::uint32_t last = kNone;  // consecutive fine points usually share a coarse voxel
  for (const Vec3f& pf : frame_fine_) {
    const Vec3d p = pf.cast<double>();
    std::int32_t key[3];
    bool ok = true;
    for (int a = 0; a < 3; ++a) {
      const double q = p(a) / cv;
      ok = ok && q > -1073741824.0 && q < 1073741824.0;
      key[a] = ok ? det::floor_to_int(q) : 0;
      ok = ok && key[a] != -1073741824;
    }
    const bool same = ok && last != kNone && coarse_[last].key[0] == key[0] && coarse_[last].key[1] == key[1] &&
                      coarse_[last].key[2] == key[2];
    std::uint32_t v = same ? last : (ok ? find_coarse(key) : kNone);
    if (ok && v == kNone && voxels < kMaxCoarse) {
      const ProbeResult probe = linear_probe(spatial_hash_folded(key), kCoarseSlots, kMaxProbes,
                                             [&](std::size_t slot) { return coarse_slots_[slot] == 0; });
      if (probe.stopped) {
        v = static_cast<std::uint32_t>(voxels++);
        coarse_[v] = CoarseVoxel{};
        for (int a = 0; a < 3; ++a) coarse_[v].key[a] = key[a];
        coarse_[v].slot = static_cast<std::uint32_t>(probe.slot);
        coarse_slots_[probe.slot] = v + 1;
      }
    }
    if (v == kNone) {
      ++r.points_dropped_capacity;
      continue;
    }
    last = v;
    CoarseVoxel& c = coarse_[v];
    ++c.count;
    c.sum += p;
    // The upper triangle of p p^T (p_i p_j == p_j p_i bit for bit: the full matrix adds nothing).
    c.outer[0] += p.x() * p.x();
    c.outer[1] += p.x() * p.y();
    c.outer[2] += p.x() * p.z();
    c.outer[3] += p.y() * p.y();
    c.outer[4] += p.y() * p.z();
    c.outer[5] += p.z() * p.z();
  }
  for (std::size_t v = 0; v < voxels; ++v) {
    const CoarseVoxel& c = coarse_[v];
    const Vec3d mean = c.sum / static_cast<double>(c.count);
    frame_coarse_.push_back(mean.cast<float>());
    coarse_normals_[v] = params_.point_to_plane ? coarse_normal(static_cast<std::uint32_t>(v), mean, cv) : Vec3f::Zero();
  }
  for (std::size_t v = 0; v < voxels; ++v) coarse_slots_[coarse_[v].slot] = 0;
}

std::uint32_t LidarOdometry::find_coarse(const std::int32_t key[3]) const {
  return find_indexed(coarse_slots_, kCoarseSlots, kMaxProbes, coarse_, key);
}

Vec3f LidarOdometry::coarse_normal(std::uint32_t self, const Vec3d& mean, double cv) const {
  const std::int32_t* key = coarse_[self].key;
  std::int32_t side[3];
  for (int a = 0; a < 3; ++a) side[a] = mean(a) / cv - key[a] < 0.5 ? -1 : 1;
  Vec3d sum = Vec3d::Zero();
  double outer[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  std::uint32_t n = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const std::int32_t k[3] = {key[0] + ((corner & 1) ? side[0] : 0), key[1] + ((corner & 2) ? side[1] : 0),
                               key[2] + ((corner & 4) ? side[2] : 0)};
    const std::uint32_t v = corner == 0 ? self : find_coarse(k);
    if (v == kNone) continue;
    sum += coarse_[v].sum;
    for (int e = 0; e < 6; ++e) outer[e] += coarse_[v].outer[e];
    n += coarse_[v].count;
  }
  if (n < params_.normal_min_points) return Vec3f::Zero();  // no plane to speak of: not used
  const Vec3d centroid = sum / static_cast<double>(n);
  Mat3d moments;
  moments << outer[0], outer[1], outer[2], outer[1], outer[3], outer[4], outer[2], outer[4], outer[5];
  const Mat3d cov = moments / static_cast<double>(n) - centroid * centroid.transpose();
  return smallest_eigenvector3(cov).cast<float>();
}

// Gauss-Newton with a Geman-McClure kernel, left-multiplied twist (rho, omega).
Mat4d LidarOdometry::align(const Mat4d& prediction, OdometryResult& r) {
  const double tau = r.threshold;
  const double kappa = r.sigma / 3.0;
  const double k2 = kappa * kappa;
  Mat4d T = prediction;
  r.status = OdometryStatus::kOk;
  const std::uint64_t per_iteration = frame_coarse_.size();
  for (std::size_t i = 0; i < frame_coarse_.size(); ++i) blocks_[i].lo[0] = OdometryVoxelMap::kNoBlock;
  for (std::uint32_t it = 0; it < params_.max_iterations; ++it) {
    if (it > 0 && params_.max_queries > 0 && (it + 1) * per_iteration > params_.max_queries) {
      r.query_capped = true;
      break;
    }
    Mat6d H = Mat6d::Zero();
    Vec6d b = Vec6d::Zero();
    double sse = 0.0;
    std::uint32_t matches = 0;
    const Mat3d R = T.topLeftCorner<3, 3>();
    for (std::size_t i = 0; i < frame_coarse_.size(); ++i) {
      Vec3d n = Vec3d::Zero();
      if (params_.point_to_plane) {
        n = R * coarse_normals_[i].cast<double>();
        if (n.squaredNorm() < 0.5) continue;  // no normal (isolated point): no search either
      }
      const Vec3d p = transform(T, frame_coarse_[i]);
      Vec3d q;
      double d2;
      if (!map_.nearest(p, tau * tau, q, d2, blocks_[i])) continue;
      const Vec3d res = p - q;
      if (params_.point_to_plane) {
        const double e = n.dot(res);
        const double denom = k2 + e * e;
        const double w = k2 / (denom * denom) * k2;
        Vec6d jn;
        jn.head<3>() = n;
        jn.tail<3>() = p.cross(n);  // n^T [I | -[p]x]
        add_weighted_outer_lower(H, w, jn);
        b += (w * e) * jn;
        sse += e * e;
      } else {
        Eigen::Matrix<double, 3, 6> J;
        J.leftCols<3>() = Mat3d::Identity();
        J.rightCols<3>() = -skew(p);
        const double denom = k2 + d2;
        const double w = k2 / (denom * denom) * k2;  // normalised so w(0) = 1
        const Mat6d JtJ = J.transpose() * J;
        H.triangularView<Eigen::Lower>() += w * JtJ;
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
    mirror_lower(H);
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
  return T;
}

}  // namespace v2xloc
