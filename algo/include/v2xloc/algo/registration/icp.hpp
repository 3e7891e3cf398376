// Iterative closest point, point-to-point and point-to-plane, as Gauss-Newton on se(3)
// (6x6 normal equations accumulated serially in double; Besl & McKay 1992, Chen & Medioni 1992;
// linearisation as in Low 2004 / Open3D TransformationEstimationPointToPlane), with an optional
// robust kernel as iteratively reweighted least squares (Babin et al., "Analysis of robust
// functions for registration algorithms", ICRA 2019). No storage: correspondences are found and
// accumulated on the fly, so each iteration is one nearest-neighbour pass over the source.
//
// Convergence follows Open3D's ICPConvergenceCriteria: after each update, fitness and inlier RMSE
// are re-evaluated; the loop stops when both changed by less than relative_fitness /
// relative_rmse, or after max_iterations updates (then converged = false, status kOk).
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/registration/kabsch.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/search/proximity_grid.hpp"
#include "v2xloc/algo/registration/registration_result.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

enum class IcpMethod : std::uint8_t { kPointToPoint, kPointToPlane };

enum class RobustKernelType : std::uint8_t {
  kNone,          // plain least squares
  kHuber,         // w = 1 for |r| <= k, k/|r| beyond
  kTukey,         // w = (1 - (r/k)^2)^2 for |r| <= k, 0 beyond
  kCauchy,        // w = 1 / (1 + (r/k)^2)
  kGemanMcClure,  // w = k^2 / (k^2 + r^2)^2 * k^2  (normalised so w(0) = 1)
};

struct RobustKernel {
  RobustKernelType type = RobustKernelType::kNone;
  double scale = 0.1;  // k [m], the residual where down-weighting starts
  // IRLS weight of a residual r [m] (point-to-point: |p - q|; point-to-plane: n.(p - q)).
  double weight(double residual) const;
};

struct IcpCriteria {
  double relative_fitness = 1e-6;  // stop when |fitness_k - fitness_{k-1}| < this ...
  double relative_rmse = 1e-6;     // ... and |rmse_k - rmse_{k-1}| < this [m]
  std::uint32_t max_iterations = 30;  // clamped to config::kIcpMaxIterations
};

struct IcpParams {
  IcpMethod method = IcpMethod::kPointToPlane;
  double max_correspondence_distance = 1.0;  // [m], pairs farther apart are ignored
  IcpCriteria criteria{};
  RobustKernel kernel{};
  // Degenerate if the smallest eigenvalue of the (diagonally normalised) normal matrix is below
  // this fraction of the largest (a single plane leaves 3 DoF unobserved for point-to-plane;
  // collinear pairs one for point-to-point).
  double min_eigenvalue_ratio = 1e-8;
  // [work units] per run: one a source point, plus the k-d tree nodes its query visited and the
  // map normals it had computed (~110 instructions a unit, pose_search.hpp). A run that spends them
  // ends like one at its iteration cap (kDidNotConverge, the last full pass's estimate). 0: none.
  std::uint64_t max_work = 0;
};

// The (map) target as a view: reusable across frames without rebuilding. normals may be empty
// for point-to-point; for point-to-plane it must have points.size() entries. tree must be built
// over exactly `points`. vicinity (optional, ready, built over the same points): a source point it
// proves has no target point within its reach needs no tree search when the correspondence gate
// is within that reach (same result: about half the tracking queries have no match).
// lazy_normals (optional): normals computed on first use (registration/lazy_normals.hpp), read
// instead of `normals` (which still gives their storage).
class LazyNormals;
struct IcpTarget {
  std::span<const Vec3f> points{};
  std::span<const Vec3f> normals{};
  const KdTree<Vec3f>* tree = nullptr;
  const ProximityGrid* vicinity = nullptr;
  LazyNormals* lazy_normals = nullptr;
};

// Registers source to target starting from `initial` (p_target = T p_source).
// Returns kOk (converged or hit the cap; result.converged tells which), kInvalidInput (bad
// params / missing tree / normals), kNotEnoughPoints (< 3 valid source or target points),
// kNoCorrespondences (nothing within max distance at some iteration), kDegenerate (normal
// matrix rank-deficient; transform is the last well-posed estimate). Never NaN: on any failure
// result.transform is the last finite estimate (initially `initial`).
// fitness / inlier_rmse / inliers / information refer to result.transform.
// neighbor_scratch (optional, >= source.size() entries, overwritten): each point's match of the
// last iteration seeds its next search; same result, fewer tree nodes visited.
RegistrationResult icp(std::span<const Vec3f> source, const IcpTarget& target,
                       const Mat4d& initial, const IcpParams& params,
                       std::span<std::uint32_t> neighbor_scratch = {});

// One nearest-neighbour pass at a transform, as it accumulates: evaluation (fitness / RMSE /
// information) plus the system of the chosen method, summed in source order (deterministic).
struct IcpPass {
  std::uint32_t valid_source = 0;
  std::uint32_t inliers = 0;
  double squared_error_sum = 0.0;
  // Information, closed form of sum J^T J with J = [-[q]x | I]: needs sum q q^T, sum q, count.
  Mat3d qq_sum = Mat3d::Zero();
  Vec3d q_sum = Vec3d::Zero();
  // Point-to-plane normal equations.
  Mat6d h = Mat6d::Zero();
  Vec6d b = Vec6d::Zero();
  // Point-to-point: weighted Kabsch (the exact minimiser of the weighted problem).
  KabschAccumulator kabsch;
  std::uint32_t search_truncated = 0;
  std::uint64_t node_visits = 0;  // k-d tree nodes visited (the pass's real search work)
};

// The same ICP in slices (a search spread over several periods): icp_begin checks the inputs,
// each icp_continue runs at most max_passes nearest-neighbour passes over the source, and stops
// inside a pass once max_work work units are spent (one per source point plus the k-d tree
// nodes its query visited: a pass from a wrong pose can cost 100x one near the map). It returns
// true once finished; run.result is then what icp() returns (bit-identical). source, target,
// params and neighbor_scratch must be the same in every call of one run.
struct IcpRun {
  RegistrationResult result{};
  Mat4d transform = Mat4d::Identity();
  double prev_fitness = 0.0;
  double prev_rmse = 0.0;
  std::uint32_t passes = 0;   // nearest-neighbour passes completed
  std::uint64_t work = 0;     // work units spent so far
  IcpPass pass{};             // the pass in progress (when in_pass)
  std::uint32_t cursor = 0;   // its next source point
  bool in_pass = false;
  bool finished = true;
};
void icp_begin(IcpRun& run, std::span<const Vec3f> source, const IcpTarget& target, const Mat4d& initial,
               const IcpParams& params, std::span<std::uint32_t> neighbor_scratch = {});
bool icp_continue(IcpRun& run, std::span<const Vec3f> source, const IcpTarget& target,
                  const IcpParams& params, std::uint32_t max_passes,
                  std::span<std::uint32_t> neighbor_scratch = {}, std::uint64_t max_work = ~std::uint64_t{0});

// Open3D's evaluate_registration: fitness, inlier RMSE, inliers and the information matrix of
// `transform` without iterating (status kOk, kNoCorrespondences, kNotEnoughPoints or
// kInvalidInput). stride > 1 judges every stride-th source point only (points 0, stride, ...):
// a decision that must fit a period's remaining budget (0: kInvalidInput).
RegistrationResult evaluate_registration(std::span<const Vec3f> source, const IcpTarget& target,
                                         const Mat4d& transform, double max_correspondence_distance,
                                         std::uint32_t stride = 1);

}  // namespace v2xloc
