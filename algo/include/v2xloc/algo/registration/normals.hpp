// PCA surface normals over hybrid radius / max-nn neighbourhoods (Open3D EstimateNormals with
// KDTreeSearchParamHybrid, then orient_normals_towards_camera_location).
//   covariance  of the neighbourhood (the point itself included), centred two-pass, double
//   normal      eigenvector of the smallest eigenvalue (cyclic Jacobi, +,-,*,/,sqrt only:
//               the same bits on every ISA)
//   orientation flipped so that normal . (viewpoint - p) >= 0
// Degenerate neighbourhoods are flagged and counted, with a defined normal:
//   < 3 neighbours or all coincident -> (0,0,1) then oriented (what Open3D yields)
//   collinear (middle eigenvalue <= collinear_ratio * largest) -> the unit vector
//               perpendicular to the line that is closest to the viewpoint direction
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct NormalParams {
  float radius = 1.0f;                                // m, hybrid search radius
  std::size_t max_nn = config::kNormalMaxNeighbors;   // clamped to config::kMaxNeighbors
  Vec3f viewpoint = Vec3f::Zero();                    // sensor origin, cloud frame
  bool orient_to_viewpoint = true;
  double collinear_ratio = 1e-6;   // middle / largest eigenvalue below this: a line, not a surface
};

enum class NormalQuality : std::uint8_t {
  kOk = 0,
  kFewNeighbors = 1,   // < 3 neighbours or zero spread
  kCollinear = 2,
  kNonFinitePoint = 3, // input point not finite (not in the tree): normal (0,0,1), not oriented
};

enum class NormalsStatus : std::uint8_t {
  kOk,
  kEmptyTree,
  kInvalidParams,   // radius not finite / <= 0, max_nn == 0, or output too small
};

struct NormalsResult {
  NormalsStatus status = NormalsStatus::kEmptyTree;
  std::uint32_t points = 0;
  std::uint32_t few_neighbors = 0;
  std::uint32_t collinear = 0;
  std::uint32_t non_finite = 0;
  std::uint32_t max_nn_clamped = 0;     // 1 when max_nn > config::kMaxNeighbors was reduced
  KdQueryCounters search;
};

// Normals of every point of tree.points() (normals.size() >= that). quality (optional, empty
// span to skip) receives one NormalQuality per point.
NormalsResult estimate_normals(const KdTree<Vec3f>& tree, const NormalParams& params,
                               std::span<Vec3f> normals,
                               std::span<NormalQuality> quality = {});
// Normals of points [first, first + count) of tree.points() only (clamped to the cloud; the rest
// of `normals` is left as it is), each exactly as the whole-cloud call computes it: a caller can
// spread one cloud's normals over several calls (bounded work per call).
NormalsResult estimate_normals_range(const KdTree<Vec3f>& tree, const NormalParams& params,
                                     std::size_t first, std::size_t count, std::span<Vec3f> normals);
// Same, with the neighbourhoods taken from a shared cache (e.g. the FPFH search, when
// params.radius / max_nn do not exceed the cache's): the same normals, bit for bit.
NormalsResult estimate_normals(const KdNeighborhoods& neighborhoods, const NormalParams& params,
                               std::span<Vec3f> normals,
                               std::span<NormalQuality> quality = {});

}  // namespace v2xloc
