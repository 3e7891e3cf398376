// Fast Point Feature Histograms (Rusu, Blodow, Beetz, ICRA 2009), 33 = 3 x 11 bins, following
// Open3D 0.16 ComputeFPFHFeature exactly:
//   neighbourhood   hybrid search (radius, max_nn) incl. the point itself; the first (nearest)
//                   entry is taken as the point itself and skipped
//   pair feature    Darboux frame of (p1,n1,p2,n2) with the source chosen as the point whose
//                   normal makes the smaller angle with the connecting line:
//                   f0 = atan2(w.n2, u.n2) (theta), f1 = v.n2 (alpha), f2 = u.d/|d| (phi);
//                   a zero-length d or a zero u x d gives the feature (0,0,0)
//   bins            bins 0-10: floor(11 (f0 + pi) / 2pi); 11-21: floor(11 (f1 + 1) / 2);
//                   22-32: floor(11 (f2 + 1) / 2), each clamped to [0,10]
//   SPFH            each pair adds 100 / (n - 1) to its three bins (n = neighbours incl. self);
//                   a point with n <= 1 has an all-zero SPFH and FPFH
//   FPFH            F(p) = SPFH(p) + sum_k SPFH(p_k) / d_k^2 (d_k^2 the squared distance;
//                   neighbours at zero distance skipped), the weighted sum normalised so each
//                   11-bin block sums to 100 (blocks with zero sum left at zero)
// Angles use det::atan2 (same bits on every ISA). Pairs whose feature is not finite (NaN normal)
// are skipped and counted.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct FpfhParams {
  float radius = 0.25f;                              // m (Open3D examples: 5 x voxel size)
  std::size_t max_nn = config::kFpfhMaxNeighbors;    // clamped to config::kMaxNeighbors
};

enum class FpfhStatus : std::uint8_t {
  kOk,
  kEmptyTree,
  kInvalidParams,   // radius not finite / <= 0, max_nn < 2, or a buffer too small
};

struct FpfhResult {
  FpfhStatus status = FpfhStatus::kEmptyTree;
  std::uint32_t points = 0;
  std::uint32_t isolated = 0;           // points with no neighbour but themselves: zero feature
  std::uint32_t non_finite_points = 0;  // not in the tree: zero feature
  std::uint32_t non_finite_pairs = 0;   // pair features skipped (non-finite normal)
  std::uint32_t max_nn_clamped = 0;
  KdQueryCounters search;
};

// The pair feature (f0, f1, f2, |d|); exposed for tests.
struct PairFeature {
  double f0, f1, f2, distance;
};
PairFeature fpfh_pair_feature(const Vec3d& p1, const Vec3d& n1, const Vec3d& p2, const Vec3d& n2);

// Features of every point of tree.points(). normals: one per point. spfh_scratch and features:
// at least tree.points().size() entries each (spfh_scratch is overwritten).
FpfhResult compute_fpfh(const KdTree<Vec3f>& tree, std::span<const Vec3f> normals,
                        const FpfhParams& params, std::span<Feature33> spfh_scratch,
                        std::span<Feature33> features);
// Same, with both passes reading the neighbourhoods from a shared cache (built with this
// radius / max_nn or larger ones): the same features, bit for bit, one search per point.
FpfhResult compute_fpfh(const KdNeighborhoods& neighborhoods, std::span<const Vec3f> normals,
                        const FpfhParams& params, std::span<Feature33> spfh_scratch,
                        std::span<Feature33> features);

}  // namespace v2xloc
