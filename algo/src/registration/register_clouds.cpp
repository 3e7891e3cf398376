#include "v2xloc/algo/registration/register_clouds.hpp"

#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/symmetric_eigen.hpp"

namespace v2xloc {
namespace {

class StageTimer {
 public:
  StageTimer(TickClock clock, RegisterStageStats& stats) : clock_(clock), stats_(stats) {
    start_ = last_ = now();
  }
  void lap(RegisterStage stage) {
    const std::uint64_t t = now();
    stats_.ticks[static_cast<int>(stage)] += t - last_;
    last_ = t;
    stats_.total_ticks = t - start_;
  }

 private:
  std::uint64_t now() const { return clock_ != nullptr ? clock_() : 0; }
  TickClock clock_;
  RegisterStageStats& stats_;
  std::uint64_t start_ = 0, last_ = 0;
};

std::uint32_t overflow_of(const VoxelDownsampleResult& r) {
  return r.output_overflow + r.hash_overflow + r.range_overflow;
}

// A cloud whose scatter has a (near) zero middle eigenvalue is a line or a point: no rigid
// registration is defined (rotation about the line is unobservable).
bool is_collinear(std::span<const Vec3f> cloud) {
  if (cloud.size() < 3) return true;
  Vec3d mean = Vec3d::Zero();
  for (const Vec3f& p : cloud) mean += p.cast<double>();
  mean /= static_cast<double>(cloud.size());
  Mat3d cov = Mat3d::Zero();
  for (const Vec3f& p : cloud) {
    const Vec3d d = p.cast<double>() - mean;
    cov += d * d.transpose();
  }
  Vec3d eigenvalues;
  Mat3d eigenvectors;
  symmetric_eigen3(cov, eigenvalues, eigenvectors);
  return !(eigenvalues(1) > 1e-10 * eigenvalues(2)) || !(eigenvalues(2) > 0.0);
}

}  // namespace

RegisterCloudsResult register_clouds(std::span<const Vec3f> source, std::span<const Vec3f> target,
                                     const RegisterCloudsParams& params, const Mat4d& initial,
                                     RegistrationWorkspace& ws) {
  RegisterCloudsResult out;
  RegistrationResult& reg = out.registration;
  RegisterStageStats& stats = out.stats;
  reg.transform = params.mode == RegistrationMode::kIcpOnly ? initial : Mat4d::Identity();
  out.coarse.transform = reg.transform;
  stats.source_input = static_cast<std::uint32_t>(source.size());
  stats.target_input = static_cast<std::uint32_t>(target.size());
  const float voxel = params.voxel_size;
  if (!std::isfinite(voxel) || !(voxel > 0.0f) || !initial.allFinite() ||
      !(params.normal_radius_voxels > 0.0f) || !(params.fpfh_radius_voxels > 0.0f) ||
      !(params.ransac_distance_voxels > 0.0) || !(params.icp_distance_voxels > 0.0) ||
      !(params.icp_kernel_voxels > 0.0)) {
    reg.status = RegistrationStatus::kInvalidInput;
    out.coarse.status = reg.status;
    return out;
  }
  StageTimer timer(params.clock, stats);

  // Truncate what does not fit a scan buffer (counted, never silent).
  if (source.size() > config::kMaxScanPoints) {
    stats.source_truncated = static_cast<std::uint32_t>(source.size() - config::kMaxScanPoints);
    source = source.first(config::kMaxScanPoints);
  }
  if (target.size() > config::kMaxScanPoints) {
    stats.target_truncated = static_cast<std::uint32_t>(target.size() - config::kMaxScanPoints);
    target = target.first(config::kMaxScanPoints);
  }

  // 1. Downsampling (one hash table, reused: the stage leaves it empty).
  const VoxelDownsampleResult ds_source = ws.voxel.run(source, voxel, ws.source_down);
  const VoxelDownsampleResult ds_target = ws.voxel.run(target, voxel, ws.target_down);
  timer.lap(RegisterStage::kDownsample);
  stats.source_downsampled = static_cast<std::uint32_t>(ws.source_down.size());
  stats.target_downsampled = static_cast<std::uint32_t>(ws.target_down.size());
  stats.downsample_overflow = overflow_of(ds_source) + overflow_of(ds_target);
  reg.nonfinite_dropped = ds_source.non_finite_dropped + ds_target.non_finite_dropped;
  reg.overflow_dropped = stats.source_truncated + stats.target_truncated + stats.downsample_overflow;
  auto finish = [&](RegistrationStatus status) {
    reg.status = status;
    if (params.mode == RegistrationMode::kIcpOnly || out.coarse.status == RegistrationStatus::kInvalidInput) {
      out.coarse.status = status;
    }
    reg.nonfinite_dropped = ds_source.non_finite_dropped + ds_target.non_finite_dropped;
    reg.overflow_dropped = stats.source_truncated + stats.target_truncated +
                           stats.downsample_overflow + stats.correspondences_truncated;
    return out;
  };
  if (ws.source_down.size() < 3 || ws.target_down.size() < 3) {
    return finish(RegistrationStatus::kNotEnoughPoints);
  }
  const std::span<const Vec3f> src = ws.source_down.span();
  const std::span<const Vec3f> tgt = ws.target_down.span();
  if (is_collinear(src) || is_collinear(tgt)) return finish(RegistrationStatus::kDegenerate);

  // 2./3. Trees, normals, FPFH. In global mode each cloud is searched once at the FPFH radius
  // and the lists feed its normals (a prefix, see KdNeighborhoods) and both FPFH passes; the
  // list storage is reused for the second cloud. ICP-only mode needs just the target normals.
  const bool global = params.mode == RegistrationMode::kGlobal;
  NormalParams np;
  np.radius = params.normal_radius_voxels * voxel;
  np.max_nn = params.normal_max_nn;
  FpfhParams fp;
  fp.radius = params.fpfh_radius_voxels * voxel;
  fp.max_nn = params.fpfh_max_nn;
  const std::span<Feature33> scratch(ws.spfh_scratch, RegistrationWorkspace::kMaxPoints);
  const std::span<Feature33> fsrc(ws.source_features, src.size());
  const std::span<Feature33> ftgt(ws.target_features, tgt.size());
  // Normals (and, in global mode, features) of one cloud; false: the tree could not be built.
  const auto describe = [&](std::span<const Vec3f> cloud, KdTreeStorage<Vec3f, RegistrationWorkspace::kMaxPoints>& tree,
                            const Vec3f& viewpoint, Vec3f* normals_out, std::span<Feature33> features,
                            FpfhStatus& fpfh_status) {
    if (tree.build(cloud).status != KdBuildStatus::kOk) return false;
    const std::span<Vec3f> normals(normals_out, cloud.size());
    np.viewpoint = viewpoint;
    KdNeighborhoods lists(tree.tree);
    if (global) {
      lists.build(fp.radius > np.radius ? fp.radius : np.radius,
                  fp.max_nn > np.max_nn ? fp.max_nn : np.max_nn,
                  std::span<KdNeighborhoods::Slot>(ws.neighborhood_entries, RegistrationWorkspace::kListEntries),
                  std::span<std::uint32_t>(ws.mutual_scratch, RegistrationWorkspace::kMaxPoints),
                  std::span<std::uint8_t>(ws.neighborhood_count, RegistrationWorkspace::kListPoints));
      stats.search_cap_hits += lists.build_search().visit_cap_hits;
      stats.neighborhoods_not_cached += lists.not_cached();
      timer.lap(RegisterStage::kFpfh);
    }
    const NormalsResult nr = estimate_normals(lists, np, normals);
    stats.search_cap_hits += nr.search.visit_cap_hits;
    timer.lap(RegisterStage::kNormals);
    if (global) {
      const FpfhResult fr = compute_fpfh(lists, normals, fp, scratch, features);
      stats.search_cap_hits += fr.search.visit_cap_hits;
      fpfh_status = fr.status;
      timer.lap(RegisterStage::kFpfh);
    }
    return true;
  };
  FpfhStatus fpfh_source = FpfhStatus::kOk, fpfh_target = FpfhStatus::kOk;
  if (global && !describe(src, ws.source_tree, params.source_viewpoint, ws.source_normals, fsrc, fpfh_source)) {
    return finish(RegistrationStatus::kNotEnoughPoints);
  }
  if (!describe(tgt, ws.target_tree, params.target_viewpoint, ws.target_normals, ftgt, fpfh_target)) {
    return finish(RegistrationStatus::kNotEnoughPoints);
  }

  Mat4d start = initial;
  if (global) {
    if (fpfh_source != FpfhStatus::kOk || fpfh_target != FpfhStatus::kOk) {
      return finish(RegistrationStatus::kInvalidInput);
    }

    // 4. Nearest-feature correspondences (optionally mutual).
    ws.target_feature_tree.build(std::span<const Feature33>(ftgt));
    const KdTree<Feature33>* source_feature_tree = nullptr;
    if (params.mutual_filter) {
      ws.source_feature_tree.build(std::span<const Feature33>(fsrc));
      source_feature_tree = &ws.source_feature_tree.tree;
    }
    // Exact projection pre-filter for the 33-D searches: principal axes of both feature sets;
    // the SPFH scratch is free once the features exist: first the Jacobi matrices, then the
    // projections (source point i at spfh_scratch[i][0..7], target at [8..15]).
    CorrespondenceParams cp;
    cp.mutual_filter = params.mutual_filter;
    compute_feature_basis(fsrc, ftgt, 4, scratch, ws.feature_basis);
    float* const projections = ws.spfh_scratch[0].data();
    constexpr std::size_t kStride = sizeof(Feature33) / sizeof(float);
    static_assert(kStride == kFpfhBins && 2 * FeatureBasis::kAxes <= kFpfhBins);
    const float max_abs =
        std::max(project_features(fsrc, ws.feature_basis, projections, kStride),
                 project_features(ftgt, ws.feature_basis, projections + FeatureBasis::kAxes, kStride));
    cp.projections = {projections, projections + FeatureBasis::kAxes, kStride};
    ws.target_feature_tree.tree.set_projections(cp.projections.target, kStride, max_abs);
    if (source_feature_tree != nullptr) {
      ws.source_feature_tree.tree.set_projections(cp.projections.source, kStride, max_abs);
    }
    const bool approximate = params.feature_search_visits > 0 &&
                             params.feature_search_visits < config::kKdMaxNodeVisits;
    const std::size_t visits =
        approximate ? params.feature_search_visits : config::kKdMaxNodeVisits;
    ws.target_feature_tree.tree.set_max_node_visits(visits);
    ws.source_feature_tree.tree.set_max_node_visits(visits);
    const CorrespondenceResult cr = match_features(
        fsrc, ws.target_feature_tree.tree, cp, ws.correspondences, source_feature_tree,
        std::span<std::uint32_t>(ws.mutual_scratch, RegistrationWorkspace::kMaxPoints));
    stats.correspondences = cr.count;
    stats.correspondences_truncated = cr.truncated;
    if (approximate) {
      stats.feature_queries_cut += cr.search.visit_cap_hits;
    } else {
      stats.search_cap_hits += cr.search.visit_cap_hits;
    }
    timer.lap(RegisterStage::kCorrespondences);
    if (cr.count < 3) {
      out.coarse.status = RegistrationStatus::kNoCorrespondences;
      return finish(RegistrationStatus::kNoCorrespondences);
    }

    // 5. RANSAC.
    RansacParams rp = params.ransac;
    rp.max_correspondence_distance = params.ransac_distance_voxels * voxel;
    rp.distance_check_threshold = rp.max_correspondence_distance;
    const RansacResult rr = ransac(src, tgt, ws.correspondences.span(), ws.target_tree.tree, rp);
    timer.lap(RegisterStage::kRansac);
    out.coarse = rr.registration;
    stats.ransac_validations = rr.validations;
    stats.ransac_correspondence_inliers = rr.correspondence_inliers;
    if (!rr.registration.ok()) return finish(rr.registration.status);
    start = rr.registration.transform;
  }

  // 6. ICP refinement against the target view.
  IcpParams ip = params.icp;
  ip.max_correspondence_distance = params.icp_distance_voxels * voxel;
  ip.kernel.scale = params.icp_kernel_voxels * voxel;
  IcpTarget view;
  view.points = tgt;
  view.normals = std::span<const Vec3f>(ws.target_normals, tgt.size());
  view.tree = &ws.target_tree.tree;
  // The mutual-match scratch is free by now: it holds the per-point warm-start matches.
  const RegistrationResult fine =
      icp(src, view, start, ip, std::span<std::uint32_t>(ws.mutual_scratch, RegistrationWorkspace::kMaxPoints));
  timer.lap(RegisterStage::kIcp);
  stats.icp_iterations = fine.iterations;
  stats.search_cap_hits += fine.search_truncated;
  reg = fine;
  return finish(fine.status);
}

}  // namespace v2xloc
