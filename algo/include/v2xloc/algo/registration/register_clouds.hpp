// The registration pipeline as one call: voxel downsampling -> normals -> FPFH -> feature
// correspondences -> RANSAC -> ICP (mode kGlobal), or downsampling -> normals -> ICP from an
// initial guess (mode kIcpOnly), or downsampling -> target normals -> level search (x, y, yaw
// lattice scored by occupancy overlap, level_search.hpp) -> ICP of the best hypotheses (mode
// kLevelSearch, centred on the initial guess; needs the LevelSearchWorkspace overload). Parameters derive from the voxel size as in Open3D's global
// registration tutorial (normals radius 2 voxels / 30 nn, FPFH 5 voxels / 100 nn, RANSAC
// distance 1.5 voxels; final point-to-plane ICP gated at 1 voxel with Tukey's biweight at 0.5
// voxel). In global mode each cloud is searched once per point (KdNeighborhoods) for its normals
// and FPFH (exact: the same results as separate searches); the 33-D feature searches use an
// exact principal-axis projection pre-filter and optionally a node-visit budget that makes
// them approximate (feature_search_visits; 0 = exact, the default). All storage lives in a
// RegistrationWorkspace the caller owns:
//   static RegistrationWorkspace ws;   // once; large (see sizeof), never on the stack
//   RegisterCloudsResult r = register_clouds(source, target, params, Mat4d::Identity(), ws);
// Times are ticks of a caller-supplied clock (algo has no OS); null -> all zero.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/registration/correspondences.hpp"
#include "v2xloc/algo/registration/fpfh.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/registration/level_search.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/registration/ransac.hpp"
#include "v2xloc/algo/registration/registration_result.hpp"
#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/registration/voxel_downsample.hpp"

namespace v2xloc {

enum class RegistrationMode : std::uint8_t { kGlobal, kIcpOnly, kLevelSearch };

using TickClock = std::uint64_t (*)();

struct RegisterCloudsParams {
  RegistrationMode mode = RegistrationMode::kGlobal;
  float voxel_size = 0.5f;                  // [m]
  float normal_radius_voxels = 2.0f;        // Open3D tutorial: 2 voxels, 30 nn
  std::size_t normal_max_nn = config::kNormalMaxNeighbors;
  float fpfh_radius_voxels = 5.0f;          // Open3D tutorial: 5 voxels, 100 nn
  std::size_t fpfh_max_nn = config::kFpfhMaxNeighbors;
  bool mutual_filter = true;                // raises the RANSAC inlier ratio a lot outdoors
  double ransac_distance_voxels = 1.5;      // Open3D tutorial
  double icp_distance_voxels = 1.0;         // final refinement gate
  // Scale k of the final ICP's robust kernel (icp.kernel.type, Tukey's biweight by default)
  // [voxels]. Plain least squares inside a 1-voxel gate lets residuals up to the gate (parts
  // of one scan the other does not see) pull the fit: on the outdoor pair at voxel 0.5 m it
  // drifts from a 0.6 deg RANSAC start into a 1.2 deg limit cycle (Open3D 0.16 does the same);
  // Tukey with k = 0.5 voxel ignores them (Babin et al. 2019) and converges on the true pose.
  double icp_kernel_voxels = 0.5;
  // Node-visit budget of each 33-D feature query (FLANN's "checks" idea): 0 = exact search
  // (bounded only by config::kKdMaxNodeVisits). A budget of 24 visits reaches the query's own
  // leaf and a few neighbours: on the outdoor pair (voxel 0.25 m) the matching stage is ~2x
  // faster with 1481 instead of 1488 correspondences, 494 instead of 546 RANSAC inliers and the
  // same final alignment; at voxel 0.5 m one RANSAC seed in eight then starts ICP where it
  // settles 1.25 deg off. Exact by default. Queries cut by the budget are counted
  // (feature_queries_cut), not reported as search-cap hits.
  std::size_t feature_search_visits = 0;
  Vec3f source_viewpoint = Vec3f::Zero();   // normals orientation (sensor origins)
  Vec3f target_viewpoint = Vec3f::Zero();
  RansacParams ransac{};                    // distances overwritten from the *_voxels fields
  IcpParams icp = [] {                      // max_correspondence_distance, kernel.scale
    IcpParams p;                            // overwritten from the *_voxels fields
    p.kernel.type = RobustKernelType::kTukey;
    return p;
  }();
  // Mode kLevelSearch: the lattice (radius, headings around the initial guess; defaults: no
  // prior), then each kept hypothesis (at most level_refine) refined by a coarse ICP gated at
  // level_coarse_icp_voxels (Tukey at half of it: the lattice leaves up to a step and half a
  // heading step, ~2-3 m at 50 m) and the final ICP; the fittest wins.
  LevelSearchParams level{};
  std::uint32_t level_refine = 8;           // [hypotheses] <= kLevelSearchMaxKept
  double level_coarse_icp_voxels = 3.0;     // [voxels]
  TickClock clock = nullptr;
};

enum class RegisterStage : std::uint8_t {
  kDownsample, kNormals, kFpfh, kCorrespondences, kRansac, kIcp, kSearch, kCount
};

struct RegisterStageStats {
  std::uint64_t ticks[static_cast<int>(RegisterStage::kCount)] = {};
  std::uint64_t total_ticks = 0;
  std::uint32_t source_input = 0, target_input = 0;          // points handed in
  std::uint32_t source_thinned = 0, target_thinned = 0;  // left out, evenly, beyond config::kMaxScanPoints
  std::uint32_t source_downsampled = 0, target_downsampled = 0;
  std::uint32_t downsample_overflow = 0;   // voxel output/hash/range overflow (both clouds)
  std::uint32_t voxel_coarsenings = 0;     // voxel grown x1.25 because a cloud overflowed the capacity
  float voxel_used = 0.0f;                 // [m] the voxel the stages ran at
  std::uint32_t correspondences = 0;
  std::uint32_t correspondences_truncated = 0;
  std::uint32_t ransac_validations = 0;
  std::uint32_t ransac_correspondence_inliers = 0;
  std::uint32_t icp_iterations = 0;
  std::uint64_t search_cap_hits = 0;       // k-d tree queries stopped at the visit cap
  std::uint64_t feature_queries_cut = 0;   // feature queries stopped by feature_search_visits
  std::uint32_t neighborhoods_not_cached = 0;  // FPFH/normal lists re-searched (cache full)
  std::uint64_t search_hypotheses = 0;     // level search: lattice hypotheses scored
  std::uint32_t search_refined = 0;        // level search: hypotheses refined by ICP
};

struct RegisterCloudsResult {
  RegistrationResult registration;   // the final (ICP) result; nonfinite/overflow filled
  RegistrationResult coarse;         // RANSAC result (global mode), the winning lattice hypothesis
                                     // (level search; fitness = its score), else the initial guess
  // Level search: the fittest refined hypothesis in another basin than the winner (farther than
  // level.distinct_distance or level.distinct_yaw); status kInvalidInput when there is none.
  RegistrationResult runner_up;
  RegisterStageStats stats;
};

// The projection pre-filter stores float coordinates in the SPFH scratch (a Feature33 array is
// a plain float array: 33 floats per element, no padding).
static_assert(sizeof(Feature33) == kFpfhBins * sizeof(float));

// All storage of the pipeline. ~tens of MB in the host profile: make it static.
struct RegistrationWorkspace {
  static constexpr std::size_t kMaxPoints = config::kMaxDownsampledPoints;
  VoxelDownsampleStorage<config::kVoxelHashSlots, kMaxPoints> voxel;
  FixedVector<Vec3f, kMaxPoints> source_down;
  FixedVector<Vec3f, kMaxPoints> target_down;
  KdTreeStorage<Vec3f, kMaxPoints> source_tree;
  KdTreeStorage<Vec3f, kMaxPoints> target_tree;
  // Normals/FPFH neighbour lists of one cloud at a time (KdNeighborhoods storage; the list
  // offsets live in mutual_scratch, which is free until the feature matching).
  static constexpr std::size_t kListEntries = config::kNeighborhoodCacheEntries;
  static constexpr std::size_t kListPoints = kListEntries > 0 ? kMaxPoints : 0;
  KdNeighborhoods::Slot neighborhood_entries[kListEntries > 0 ? kListEntries : 1];
  std::uint8_t neighborhood_count[kListPoints > 0 ? kListPoints : 1];
  Vec3f source_normals[kMaxPoints];
  Vec3f target_normals[kMaxPoints];
  Feature33 spfh_scratch[kMaxPoints];
  Feature33 source_features[kMaxPoints];
  Feature33 target_features[kMaxPoints];
  KdTreeStorage<Feature33, kMaxPoints> source_feature_tree;
  KdTreeStorage<Feature33, kMaxPoints> target_feature_tree;
  FeatureBasis feature_basis;   // principal axes of the features (projection pre-filter)
  std::uint32_t mutual_scratch[kMaxPoints];   // list offsets, then mutual matching, then ICP hints
  FixedVector<Correspondence, config::kMaxCorrespondences> correspondences;
};

// p_target = result.registration.transform * p_source. `initial` is the ICP start in
// kIcpOnly mode and ignored in kGlobal mode. Inputs longer than config::kMaxScanPoints are
// truncated (counted in stats and overflow_dropped); NaN/Inf points are dropped and counted.
// Mode kLevelSearch needs the overload with a LevelSearchWorkspace (kInvalidInput here).
RegisterCloudsResult register_clouds(std::span<const Vec3f> source, std::span<const Vec3f> target,
                                     const RegisterCloudsParams& params, const Mat4d& initial,
                                     RegistrationWorkspace& workspace);
RegisterCloudsResult register_clouds(std::span<const Vec3f> source, std::span<const Vec3f> target,
                                     const RegisterCloudsParams& params, const Mat4d& initial,
                                     RegistrationWorkspace& workspace, LevelSearchWorkspace& search_workspace);

}  // namespace v2xloc
