// The registration pipeline as one call: voxel downsampling -> normals -> FPFH -> feature
// correspondences -> RANSAC -> ICP (mode kGlobal), or downsampling -> normals -> ICP from an
// initial guess (mode kIcpOnly). Parameters derive from the voxel size as in Open3D's global
// registration tutorial (normals radius 2 voxels / 30 nn, FPFH 5 voxels / 100 nn, RANSAC
// distance 1.5 voxels); all storage lives in a RegistrationWorkspace the caller owns:
//   static RegistrationWorkspace ws;   // once; large (see sizeof), never on the stack
//   RegisterCloudsResult r = register_clouds(source, target, params, Mat4d::Identity(), ws);
// Times are ticks of a caller-supplied clock (algo has no OS); null -> all zero.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/bounded_vector.hpp"
#include "v2xloc/algo/config.hpp"
#include "v2xloc/algo/correspondences.hpp"
#include "v2xloc/algo/fpfh.hpp"
#include "v2xloc/algo/icp.hpp"
#include "v2xloc/algo/kdtree.hpp"
#include "v2xloc/algo/normals.hpp"
#include "v2xloc/algo/ransac.hpp"
#include "v2xloc/algo/registration_result.hpp"
#include "v2xloc/algo/types.hpp"
#include "v2xloc/algo/voxel_downsample.hpp"

namespace v2xloc {

enum class RegistrationMode : std::uint8_t { kGlobal, kIcpOnly };

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
  Vec3f source_viewpoint = Vec3f::Zero();   // normals orientation (sensor origins)
  Vec3f target_viewpoint = Vec3f::Zero();
  RansacParams ransac{};                    // distances overwritten from the *_voxels fields
  IcpParams icp{};                          // max_correspondence_distance overwritten
  TickClock clock = nullptr;
};

enum class RegisterStage : std::uint8_t {
  kDownsample, kNormals, kFpfh, kCorrespondences, kRansac, kIcp, kCount
};

struct RegisterStageStats {
  std::uint64_t ticks[static_cast<int>(RegisterStage::kCount)] = {};
  std::uint64_t total_ticks = 0;
  std::uint32_t source_input = 0, target_input = 0;          // points handed in
  std::uint32_t source_truncated = 0, target_truncated = 0;  // beyond config::kMaxScanPoints
  std::uint32_t source_downsampled = 0, target_downsampled = 0;
  std::uint32_t downsample_overflow = 0;   // voxel output/hash/range overflow (both clouds)
  std::uint32_t correspondences = 0;
  std::uint32_t correspondences_truncated = 0;
  std::uint32_t ransac_validations = 0;
  std::uint32_t ransac_correspondence_inliers = 0;
  std::uint32_t icp_iterations = 0;
  std::uint64_t search_cap_hits = 0;       // k-d tree queries stopped at the visit cap
};

struct RegisterCloudsResult {
  RegistrationResult registration;   // the final (ICP) result; nonfinite/overflow filled
  RegistrationResult coarse;         // RANSAC result (global mode), else the initial guess
  RegisterStageStats stats;
};

// All storage of the pipeline. ~tens of MB in the host profile: make it static.
struct RegistrationWorkspace {
  static constexpr std::size_t kMaxPoints = config::kMaxDownsampledPoints;
  VoxelDownsampleStorage<config::kVoxelHashSlots, kMaxPoints> voxel;
  FixedVector<Vec3f, kMaxPoints> source_down;
  FixedVector<Vec3f, kMaxPoints> target_down;
  KdTreeStorage<Vec3f, kMaxPoints> source_tree;
  KdTreeStorage<Vec3f, kMaxPoints> target_tree;
  Vec3f source_normals[kMaxPoints];
  Vec3f target_normals[kMaxPoints];
  Feature33 spfh_scratch[kMaxPoints];
  Feature33 source_features[kMaxPoints];
  Feature33 target_features[kMaxPoints];
  KdTreeStorage<Feature33, kMaxPoints> source_feature_tree;
  KdTreeStorage<Feature33, kMaxPoints> target_feature_tree;
  std::uint32_t mutual_scratch[kMaxPoints];
  FixedVector<Correspondence, config::kMaxCorrespondences> correspondences;
};

// p_target = result.registration.transform * p_source. `initial` is the ICP start in
// kIcpOnly mode and ignored in kGlobal mode. Inputs longer than config::kMaxScanPoints are
// truncated (counted in stats and overflow_dropped); NaN/Inf points are dropped and counted.
RegisterCloudsResult register_clouds(std::span<const Vec3f> source, std::span<const Vec3f> target,
                                     const RegisterCloudsParams& params, const Mat4d& initial,
                                     RegistrationWorkspace& workspace);

}  // namespace v2xloc
