#include "v2xloc/algo/registration/normals.hpp"

#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/finite.hpp"
#include "v2xloc/algo/core/symmetric_eigen.hpp"

namespace v2xloc {
namespace {

// Orientation rule of Open3D's orient_normals_towards_camera_location: flip when pointing away;
// a zero normal becomes the (normalised) direction to the camera, or (0,0,1).
Vec3d orient(const Vec3d& n, const Vec3d& to_view) {
  if (n.squaredNorm() == 0.0) {
    const double len = to_view.norm();
    return len == 0.0 ? Vec3d(0.0, 0.0, 1.0) : Vec3d(to_view / len);
  }
  return n.dot(to_view) < 0.0 ? Vec3d(-n) : n;
}

}  // namespace

NormalsResult estimate_normals(const KdTree<Vec3f>& tree, const NormalParams& params,
                               std::span<Vec3f> normals, std::span<NormalQuality> quality) {
  return estimate_normals(KdNeighborhoods(tree), params, normals, quality);
}

namespace {

bool valid_params(const NormalParams& params, std::size_t num_points, std::span<Vec3f> normals,
                  std::span<NormalQuality> quality) {
  return std::isfinite(params.radius) && params.radius > 0.0f && params.max_nn != 0 &&
         normals.size() >= num_points && (quality.empty() || quality.size() >= num_points);
}

// Two-pass centred covariance of the neighbourhood (better conditioned than Open3D's raw moments).
Mat3d neighborhood_covariance(std::span<const Vec3f> points, std::span<const Neighbor> neighbors) {
  Vec3d mean = Vec3d::Zero();
  for (const Neighbor& n : neighbors) mean += points[n.index].cast<double>();
  mean /= static_cast<double>(neighbors.size());
  Mat3d cov = Mat3d::Zero();
  for (const Neighbor& n : neighbors) {
    const Vec3d d = points[n.index].cast<double>() - mean;
    for (int a = 0; a < 3; ++a) {
      for (int b = a; b < 3; ++b) cov(a, b) += d[a] * d[b];
    }
  }
  cov(1, 0) = cov(0, 1);
  cov(2, 0) = cov(0, 2);
  cov(2, 1) = cov(1, 2);
  cov /= static_cast<double>(neighbors.size());
  return cov;
}

// Normal of point p's neighbourhood from its covariance: the least-spread eigenvector of a
// surface, or for a line the normal closest to the viewpoint direction. q: kOk, kCollinear, or
// kFewNeighbors when all neighbours coincide (normal (0,0,1)).
Vec3d neighborhood_normal(const Mat3d& cov, const Vec3f& p, const Vec3d& viewpoint,
                          double collinear_ratio, NormalQuality& q) {
  Vec3d lambda;
  Mat3d vectors;
  symmetric_eigen3(cov, lambda, vectors);
  if (!(lambda[2] > 0.0)) {
    q = NormalQuality::kFewNeighbors;
    return Vec3d(0.0, 0.0, 1.0);
  }
  if (lambda[1] <= collinear_ratio * lambda[2]) {
    q = NormalQuality::kCollinear;
    const Vec3d dir = vectors.col(2);
    Vec3d to_view = viewpoint - p.cast<double>();
    Vec3d perp = to_view - dir * dir.dot(to_view);
    if (perp.norm() <= 1e-12 * (to_view.norm() + 1.0)) perp = vectors.col(0);
    return perp.normalized();
  }
  q = NormalQuality::kOk;
  return vectors.col(0);
}

NormalsResult normals_of_range(const KdNeighborhoods& neighborhoods, const NormalParams& params,
                               std::span<Vec3f> normals, std::span<NormalQuality> quality,
                               std::size_t first, std::size_t count) {
  NormalsResult r;
  const KdTree<Vec3f>& tree = neighborhoods.tree();
  const std::span<const Vec3f> points = tree.points();
  if (tree.empty()) {
    r.status = NormalsStatus::kEmptyTree;
    return r;
  }
  if (!valid_params(params, points.size(), normals, quality)) {
    r.status = NormalsStatus::kInvalidParams;
    return r;
  }
  std::size_t max_nn = params.max_nn;
  if (max_nn > config::kMaxNeighbors) {
    max_nn = config::kMaxNeighbors;
    r.max_nn_clamped = 1;
  }
  Neighbor neighbors[config::kMaxNeighbors];
  const Vec3d viewpoint = params.viewpoint.cast<double>();
  const std::size_t begin = first < points.size() ? first : points.size();
  const std::size_t end = count < points.size() - begin ? begin + count : points.size();

  for (std::size_t i = begin; i < end; ++i) {
    const Vec3f& p = points[i];
    if (!is_finite_point(p)) {
      normals[i] = Vec3f(0.0f, 0.0f, 1.0f);
      ++r.non_finite;
      if (!quality.empty()) quality[i] = NormalQuality::kNonFinitePoint;
      continue;
    }
    const KdQueryResult kr =
        neighborhoods.get(i, params.radius, max_nn, std::span<Neighbor>(neighbors, max_nn));
    r.search.add(kr);
    NormalQuality q = NormalQuality::kFewNeighbors;
    Vec3d normal(0.0, 0.0, 1.0);
    if (kr.count >= 3) {
      const Mat3d cov = neighborhood_covariance(points, std::span<const Neighbor>(neighbors, kr.count));
      normal = neighborhood_normal(cov, p, viewpoint, params.collinear_ratio, q);
    }
    if (q == NormalQuality::kFewNeighbors) ++r.few_neighbors;
    if (q == NormalQuality::kCollinear) ++r.collinear;
    if (params.orient_to_viewpoint) normal = orient(normal, viewpoint - p.cast<double>());
    normals[i] = normal.cast<float>();
    if (!quality.empty()) quality[i] = q;
  }
  r.points = static_cast<std::uint32_t>(end - begin);
  r.status = NormalsStatus::kOk;
  return r;
}

}  // namespace

NormalsResult estimate_normals(const KdNeighborhoods& neighborhoods, const NormalParams& params,
                               std::span<Vec3f> normals, std::span<NormalQuality> quality) {
  return normals_of_range(neighborhoods, params, normals, quality, 0, neighborhoods.tree().points().size());
}

NormalsResult estimate_normals_range(const KdTree<Vec3f>& tree, const NormalParams& params,
                                     std::size_t first, std::size_t count, std::span<Vec3f> normals) {
  return normals_of_range(KdNeighborhoods(tree), params, normals, {}, first, count);
}

}  // namespace v2xloc
