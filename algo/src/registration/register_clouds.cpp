#include "v2xloc/algo/registration/register_clouds.hpp"

#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
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

// One call's state shared by its steps.
struct Pipeline {
  const RegisterCloudsParams& params;
  RegistrationWorkspace& ws;
  RegisterCloudsResult& out;
  StageTimer& timer;
  float voxel = 0.0f;
  VoxelDownsampleResult ds_source{}, ds_target{};
};

bool params_valid(const RegisterCloudsParams& params, const Mat4d& initial) {
  const float voxel = params.voxel_size;
  return std::isfinite(voxel) && voxel > 0.0f && initial.allFinite() && params.normal_radius_voxels > 0.0f &&
         params.fpfh_radius_voxels > 0.0f && params.ransac_distance_voxels > 0.0 &&
         params.icp_distance_voxels > 0.0 && params.icp_kernel_voxels > 0.0;
}

// 1. Downsampling (one hash table, reused: the stage leaves it empty). A cloud whose voxels do
// not fit the downsampled capacity is downsampled again at a coarser voxel (every radius of the
// later stages follows it) rather than cut: a cut keeps one part of the scene and drops the rest,
// which a registration cannot tell from a smaller overlap. Bounded; what still overflows is counted.
constexpr float kVoxelGrowth = 1.25f;      // ~0.64x the voxels of a surface per step
constexpr int kMaxVoxelCoarsenings = 6;    // up to 3.8x the requested voxel

// A cloud over the scan capacity (the profile's worst-case bound on the work) is used evenly
// thinned to it, counted.
bool fits(const VoxelDownsampleResult& r) { return r.output_overflow == 0; }

void downsample_both(Pipeline& p, std::span<const Vec3f> source, std::span<const Vec3f> target) {
  p.ds_source = p.ws.voxel.run(source, p.voxel, p.ws.source_down, config::kMaxScanPoints);
  p.ds_target = p.ws.voxel.run(target, p.voxel, p.ws.target_down, config::kMaxScanPoints);
}

void downsample(Pipeline& p, std::span<const Vec3f> source, std::span<const Vec3f> target) {
  RegisterStageStats& stats = p.out.stats;
  downsample_both(p, source, target);
  while ((!fits(p.ds_source) || !fits(p.ds_target)) && stats.voxel_coarsenings < kMaxVoxelCoarsenings) {
    p.voxel *= kVoxelGrowth;
    ++stats.voxel_coarsenings;
    downsample_both(p, source, target);
  }
  stats.voxel_used = p.voxel;
  stats.source_thinned = p.ds_source.thinned;
  stats.target_thinned = p.ds_target.thinned;
  p.timer.lap(RegisterStage::kDownsample);
  stats.source_downsampled = static_cast<std::uint32_t>(p.ws.source_down.size());
  stats.target_downsampled = static_cast<std::uint32_t>(p.ws.target_down.size());
  stats.downsample_overflow = overflow_of(p.ds_source) + overflow_of(p.ds_target);
  p.out.registration.nonfinite_dropped = p.ds_source.non_finite_dropped + p.ds_target.non_finite_dropped;
  p.out.registration.overflow_dropped = stats.source_thinned + stats.target_thinned + stats.downsample_overflow;
}

// The final status and the drop counts of every stage.
RegisterCloudsResult& finish(Pipeline& p, RegistrationStatus status) {
  RegisterCloudsResult& out = p.out;
  const RegisterStageStats& stats = out.stats;
  out.registration.status = status;
  if (p.params.mode == RegistrationMode::kIcpOnly || out.coarse.status == RegistrationStatus::kInvalidInput) {
    out.coarse.status = status;
  }
  out.registration.nonfinite_dropped = p.ds_source.non_finite_dropped + p.ds_target.non_finite_dropped;
  out.registration.overflow_dropped = stats.source_thinned + stats.target_thinned + stats.downsample_overflow +
                                      stats.correspondences_truncated;
  return out;
}

// 2./3. Tree, normals and, in global mode, FPFH of one cloud. In global mode the cloud is
// searched once at the FPFH radius and the lists feed its normals (a prefix, see
// KdNeighborhoods) and both FPFH passes; the list storage is reused for the second cloud.
// False: the tree could not be built.
bool describe(Pipeline& p, std::span<const Vec3f> cloud, KdTreeStorage<Vec3f, RegistrationWorkspace::kMaxPoints>& tree,
              const Vec3f& viewpoint, Vec3f* normals_out, std::span<Feature33> features, FpfhStatus& fpfh_status) {
  const bool global = p.params.mode == RegistrationMode::kGlobal;
  RegistrationWorkspace& ws = p.ws;
  RegisterStageStats& stats = p.out.stats;
  NormalParams np;
  np.radius = p.params.normal_radius_voxels * p.voxel;
  np.max_nn = p.params.normal_max_nn;
  np.viewpoint = viewpoint;
  FpfhParams fp;
  fp.radius = p.params.fpfh_radius_voxels * p.voxel;
  fp.max_nn = p.params.fpfh_max_nn;
  if (tree.build(cloud).status != KdBuildStatus::kOk) return false;
  const std::span<Vec3f> normals(normals_out, cloud.size());
  KdNeighborhoods lists(tree.tree);
  if (global) {
    lists.build(fp.radius > np.radius ? fp.radius : np.radius, fp.max_nn > np.max_nn ? fp.max_nn : np.max_nn,
                std::span<KdNeighborhoods::Slot>(ws.neighborhood_entries, RegistrationWorkspace::kListEntries),
                std::span<std::uint32_t>(ws.mutual_scratch, RegistrationWorkspace::kMaxPoints),
                std::span<std::uint8_t>(ws.neighborhood_count, RegistrationWorkspace::kListPoints));
    stats.search_cap_hits += lists.build_search().visit_cap_hits;
    stats.neighborhoods_not_cached += lists.not_cached();
    p.timer.lap(RegisterStage::kFpfh);
  }
  const NormalsResult nr = estimate_normals(lists, np, normals);
  stats.search_cap_hits += nr.search.visit_cap_hits;
  p.timer.lap(RegisterStage::kNormals);
  if (global) {
    const std::span<Feature33> scratch(ws.spfh_scratch, RegistrationWorkspace::kMaxPoints);
    const FpfhResult fr = compute_fpfh(lists, normals, fp, scratch, features);
    stats.search_cap_hits += fr.search.visit_cap_hits;
    fpfh_status = fr.status;
    p.timer.lap(RegisterStage::kFpfh);
  }
  return true;
}

// The exact projection pre-filter of the 33-D searches: principal axes of both feature sets.
// The SPFH scratch is free once the features exist: first the Jacobi matrices, then the
// projections (source point i at spfh_scratch[i][0..7], target at [8..15]).
void prepare_feature_projections(RegistrationWorkspace& ws, std::span<const Feature33> fsrc,
                                 std::span<const Feature33> ftgt, bool mutual, CorrespondenceParams& cp) {
  const std::span<Feature33> scratch(ws.spfh_scratch, RegistrationWorkspace::kMaxPoints);
  compute_feature_basis(fsrc, ftgt, 4, scratch, ws.feature_basis);
  float* const projections = ws.spfh_scratch[0].data();
  constexpr std::size_t kStride = sizeof(Feature33) / sizeof(float);
  static_assert(kStride == kFpfhBins && 2 * FeatureBasis::kAxes <= kFpfhBins);
  const float max_abs =
      std::max(project_features(fsrc, ws.feature_basis, projections, kStride),
               project_features(ftgt, ws.feature_basis, projections + FeatureBasis::kAxes, kStride));
  cp.projections = {projections, projections + FeatureBasis::kAxes, kStride};
  ws.target_feature_tree.tree.set_projections(cp.projections.target, kStride, max_abs);
  if (mutual) ws.source_feature_tree.tree.set_projections(cp.projections.source, kStride, max_abs);
}

// 4. Nearest-feature correspondences (optionally mutual); false: fewer than three.
bool find_correspondences(Pipeline& p, std::span<const Feature33> fsrc, std::span<const Feature33> ftgt) {
  RegistrationWorkspace& ws = p.ws;
  RegisterStageStats& stats = p.out.stats;
  ws.target_feature_tree.build(ftgt);
  const KdTree<Feature33>* source_feature_tree = nullptr;
  if (p.params.mutual_filter) {
    ws.source_feature_tree.build(fsrc);
    source_feature_tree = &ws.source_feature_tree.tree;
  }
  CorrespondenceParams cp;
  cp.mutual_filter = p.params.mutual_filter;
  prepare_feature_projections(ws, fsrc, ftgt, source_feature_tree != nullptr, cp);
  const bool approximate = p.params.feature_search_visits > 0 && p.params.feature_search_visits < config::kKdMaxNodeVisits;
  const std::size_t visits = approximate ? p.params.feature_search_visits : config::kKdMaxNodeVisits;
  ws.target_feature_tree.tree.set_max_node_visits(visits);
  ws.source_feature_tree.tree.set_max_node_visits(visits);
  const CorrespondenceResult cr =
      match_features(fsrc, ws.target_feature_tree.tree, cp, ws.correspondences, source_feature_tree,
                     std::span<std::uint32_t>(ws.mutual_scratch, RegistrationWorkspace::kMaxPoints));
  stats.correspondences = cr.count;
  stats.correspondences_truncated = cr.truncated;
  if (approximate) {
    stats.feature_queries_cut += cr.search.visit_cap_hits;
  } else {
    stats.search_cap_hits += cr.search.visit_cap_hits;
  }
  p.timer.lap(RegisterStage::kCorrespondences);
  return cr.count >= 3;
}

// 5. RANSAC over the correspondences: the coarse result.
const RegistrationResult& coarse_ransac(Pipeline& p, std::span<const Vec3f> src, std::span<const Vec3f> tgt) {
  RansacParams rp = p.params.ransac;
  rp.max_correspondence_distance = p.params.ransac_distance_voxels * p.voxel;
  rp.distance_check_threshold = rp.max_correspondence_distance;
  const RansacResult rr = ransac(src, tgt, p.ws.correspondences.span(), p.ws.target_tree.tree, rp);
  p.timer.lap(RegisterStage::kRansac);
  p.out.coarse = rr.registration;
  p.out.stats.ransac_validations = rr.validations;
  p.out.stats.ransac_correspondence_inliers = rr.correspondence_inliers;
  return p.out.coarse;
}

// 6. ICP refinement against the target view.
RegisterCloudsResult& refine_icp(Pipeline& p, std::span<const Vec3f> src, std::span<const Vec3f> tgt,
                                 const Mat4d& start) {
  RegistrationWorkspace& ws = p.ws;
  IcpParams ip = p.params.icp;
  ip.max_correspondence_distance = p.params.icp_distance_voxels * p.voxel;
  ip.kernel.scale = p.params.icp_kernel_voxels * p.voxel;
  IcpTarget view;
  view.points = tgt;
  view.normals = std::span<const Vec3f>(ws.target_normals, tgt.size());
  view.tree = &ws.target_tree.tree;
  // The mutual-match scratch is free by now: it holds the per-point warm-start matches.
  const RegistrationResult fine =
      icp(src, view, start, ip, std::span<std::uint32_t>(ws.mutual_scratch, RegistrationWorkspace::kMaxPoints));
  p.timer.lap(RegisterStage::kIcp);
  p.out.stats.icp_iterations = fine.iterations;
  p.out.stats.search_cap_hits += fine.search_truncated;
  p.out.registration = fine;
  return finish(p, fine.status);
}

// Whether two transforms lie in different basins: farther apart than the level search's
// distinct distance, or turned by more than its distinct yaw.
bool distinct(const Mat4d& a, const Mat4d& b, const LevelSearchParams& lp) {
  const double dt = (a.topRightCorner<3, 1>() - b.topRightCorner<3, 1>()).norm();
  const double yaw_a = det::atan2(a(1, 0), a(0, 0)), yaw_b = det::atan2(b(1, 0), b(0, 0));
  return dt > lp.distinct_distance || std::abs(det::wrap_pi(yaw_a - yaw_b)) > lp.distinct_yaw;
}

// 5'./6'. Level search around the initial guess, then coarse and final ICP of the best
// hypotheses; the fittest final result wins, the fittest in another basin is the runner-up.
RegisterCloudsResult& search_and_refine(Pipeline& p, std::span<const Vec3f> src, std::span<const Vec3f> tgt,
                                        const Mat4d& initial, LevelSearchWorkspace& sws) {
  const RegisterCloudsParams& params = p.params;
  const LevelSearchResult ls = level_search(src, tgt, initial(0, 3), initial(1, 3),
                                            det::atan2(initial(1, 0), initial(0, 0)), params.level, sws);
  p.timer.lap(RegisterStage::kSearch);
  p.out.stats.search_hypotheses = ls.hypotheses;
  if (ls.status != LevelSearchStatus::kOk) {
    return finish(p, ls.status == LevelSearchStatus::kNotEnoughPoints ? RegistrationStatus::kNotEnoughPoints
                                                                     : RegistrationStatus::kInvalidInput);
  }
  if (ls.kept_count == 0) return finish(p, RegistrationStatus::kNoCorrespondences);
  IcpParams coarse = params.icp;
  coarse.max_correspondence_distance = params.level_coarse_icp_voxels * p.voxel;
  coarse.kernel.scale = 0.5 * coarse.max_correspondence_distance;
  IcpParams fine = params.icp;
  fine.max_correspondence_distance = params.icp_distance_voxels * p.voxel;
  fine.kernel.scale = params.icp_kernel_voxels * p.voxel;
  IcpTarget view;
  view.points = tgt;
  view.normals = std::span<const Vec3f>(p.ws.target_normals, tgt.size());
  view.tree = &p.ws.target_tree.tree;
  const std::span<std::uint32_t> hints(p.ws.mutual_scratch, RegistrationWorkspace::kMaxPoints);
  const std::uint32_t refine = params.level_refine < ls.kept_count ? params.level_refine : ls.kept_count;
  RegistrationResult refined[kLevelSearchMaxKept];
  std::uint32_t winner = kLevelSearchMaxKept;
  for (std::uint32_t i = 0; i < refine; ++i) {
    const RegistrationResult c = icp(src, view, ls.kept[i].transform, coarse, hints);
    refined[i] = icp(src, view, c.status == RegistrationStatus::kOk ? c.transform : ls.kept[i].transform, fine, hints);
    p.out.stats.icp_iterations += c.iterations + refined[i].iterations;
    p.out.stats.search_cap_hits += c.search_truncated + refined[i].search_truncated;
    if (refined[i].ok() && (winner == kLevelSearchMaxKept || refined[i].fitness > refined[winner].fitness)) winner = i;
  }
  p.out.stats.search_refined = refine;
  p.timer.lap(RegisterStage::kIcp);
  if (winner == kLevelSearchMaxKept) {
    p.out.registration = refined[0];
    return finish(p, refined[0].status);
  }
  for (std::uint32_t i = 0; i < refine; ++i) {
    if (i == winner || !refined[i].ok() || !distinct(refined[i].transform, refined[winner].transform, params.level)) continue;
    if (!p.out.runner_up.ok() || refined[i].fitness > p.out.runner_up.fitness) p.out.runner_up = refined[i];
  }
  p.out.coarse.status = RegistrationStatus::kOk;
  p.out.coarse.transform = ls.kept[winner].transform;
  p.out.coarse.fitness = ls.kept[winner].score;
  p.out.registration = refined[winner];
  return finish(p, refined[winner].status);
}

RegisterCloudsResult run(std::span<const Vec3f> source, std::span<const Vec3f> target,
                         const RegisterCloudsParams& params, const Mat4d& initial, RegistrationWorkspace& ws,
                         LevelSearchWorkspace* search_ws) {
  RegisterCloudsResult out;
  out.registration.transform = params.mode == RegistrationMode::kIcpOnly ? initial : Mat4d::Identity();
  const bool search = params.mode == RegistrationMode::kLevelSearch;
  out.coarse.transform = out.registration.transform;
  out.stats.source_input = static_cast<std::uint32_t>(source.size());
  out.stats.target_input = static_cast<std::uint32_t>(target.size());
  if (!params_valid(params, initial) || (search && search_ws == nullptr)) {
    out.registration.status = RegistrationStatus::kInvalidInput;
    out.coarse.status = out.registration.status;
    return out;
  }
  StageTimer timer(params.clock, out.stats);
  Pipeline p{params, ws, out, timer, params.voxel_size};
  downsample(p, source, target);
  if (ws.source_down.size() < 3 || ws.target_down.size() < 3) return finish(p, RegistrationStatus::kNotEnoughPoints);
  const std::span<const Vec3f> src = ws.source_down.span();
  const std::span<const Vec3f> tgt = ws.target_down.span();
  if (is_collinear(src) || is_collinear(tgt)) return finish(p, RegistrationStatus::kDegenerate);

  // ICP-only mode needs just the target normals.
  const bool global = params.mode == RegistrationMode::kGlobal;
  const std::span<Feature33> fsrc(ws.source_features, src.size());
  const std::span<Feature33> ftgt(ws.target_features, tgt.size());
  FpfhStatus fpfh_source = FpfhStatus::kOk, fpfh_target = FpfhStatus::kOk;
  if (global && !describe(p, src, ws.source_tree, params.source_viewpoint, ws.source_normals, fsrc, fpfh_source)) {
    return finish(p, RegistrationStatus::kNotEnoughPoints);
  }
  if (!describe(p, tgt, ws.target_tree, params.target_viewpoint, ws.target_normals, ftgt, fpfh_target)) {
    return finish(p, RegistrationStatus::kNotEnoughPoints);
  }
  if (search) return search_and_refine(p, src, tgt, initial, *search_ws);
  if (!global) return refine_icp(p, src, tgt, initial);
  if (fpfh_source != FpfhStatus::kOk || fpfh_target != FpfhStatus::kOk) {
    return finish(p, RegistrationStatus::kInvalidInput);
  }
  if (!find_correspondences(p, fsrc, ftgt)) {
    out.coarse.status = RegistrationStatus::kNoCorrespondences;
    return finish(p, RegistrationStatus::kNoCorrespondences);
  }
  const RegistrationResult& coarse = coarse_ransac(p, src, tgt);
  if (!coarse.ok()) return finish(p, coarse.status);
  return refine_icp(p, src, tgt, coarse.transform);
}

}  // namespace

RegisterCloudsResult register_clouds(std::span<const Vec3f> source, std::span<const Vec3f> target,
                                     const RegisterCloudsParams& params, const Mat4d& initial,
                                     RegistrationWorkspace& ws) {
  return run(source, target, params, initial, ws, nullptr);
}

RegisterCloudsResult register_clouds(std::span<const Vec3f> source, std::span<const Vec3f> target,
                                     const RegisterCloudsParams& params, const Mat4d& initial,
                                     RegistrationWorkspace& ws, LevelSearchWorkspace& search_ws) {
  return run(source, target, params, initial, ws, &search_ws);
}

}  // namespace v2xloc
