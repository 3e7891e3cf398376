#include "v2xloc/algo/core/symmetric_eigen.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc {

void symmetric_eigen3(const Mat3d& input, Vec3d& eigenvalues, Mat3d& eigenvectors) {
  Mat3d a = input;
  Mat3d v = Mat3d::Identity();
  const double scale = a.cwiseAbs().maxCoeff();
  for (std::uint32_t sweep = 0; sweep < config::kJacobiMaxSweeps; ++sweep) {
    const double off = std::abs(a(0, 1)) + std::abs(a(0, 2)) + std::abs(a(1, 2));
    if (off <= 1e-300 || off <= scale * 1e-18) break;
    jacobi_sweep<double, 3>(a, &v);
  }
  // Sort ascending (stable, by index on ties) with the eigenvectors as columns.
  int order[3] = {0, 1, 2};
  for (int i = 1; i < 3; ++i) {
    for (int j = i; j > 0 && a(order[j], order[j]) < a(order[j - 1], order[j - 1]); --j) {
      std::swap(order[j], order[j - 1]);
    }
  }
  for (int i = 0; i < 3; ++i) {
    eigenvalues[i] = a(order[i], order[i]);
    eigenvectors.col(i) = v.col(order[i]);
  }
}

namespace {
Vec3d smallest_by_jacobi(const Mat3d& a) {
  Vec3d lambda;
  Mat3d vectors;
  symmetric_eigen3(a, lambda, vectors);
  return vectors.col(0);
}
}  // namespace

Vec3d smallest_eigenvector3(const Mat3d& a) {
  // Eigenvalues of A = q I + p B: those of B are 2 cos(phi + 2 pi k / 3) with cos(3 phi) = det(B) / 2.
  const double q = (a(0, 0) + a(1, 1) + a(2, 2)) / 3.0;
  const double off = a(0, 1) * a(0, 1) + a(0, 2) * a(0, 2) + a(1, 2) * a(1, 2);
  const double d0 = a(0, 0) - q, d1 = a(1, 1) - q, d2 = a(2, 2) - q;
  const double p = std::sqrt((d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * off) / 6.0);
  if (!(p > 0.0) || !std::isfinite(p) || !std::isfinite(q)) return smallest_by_jacobi(a);
  const double b00 = d0 / p, b11 = d1 / p, b22 = d2 / p;
  const double b01 = a(0, 1) / p, b02 = a(0, 2) / p, b12 = a(1, 2) / p;
  const double det = b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02);
  const double half_det = std::min(1.0, std::max(-1.0, 0.5 * det));
  const double phi = det::acos(half_det) / 3.0;
  const double l2 = q + 2.0 * p * det::cos(phi);                       // largest
  const double l0 = q + 2.0 * p * det::cos(phi + 2.0 * det::kPi / 3.0);  // smallest
  const double l1 = 3.0 * q - l2 - l0;
  if (!(l1 - l0 >= 1e-3 * (l2 - l0))) return smallest_by_jacobi(a);
  // Rows of M = A - l0 I; the columns of adj(M) are the cross products of its row pairs.
  const Vec3d r0(a(0, 0) - l0, a(0, 1), a(0, 2));
  const Vec3d r1(a(1, 0), a(1, 1) - l0, a(1, 2));
  const Vec3d r2(a(2, 0), a(2, 1), a(2, 2) - l0);
  const Vec3d c01 = r0.cross(r1), c02 = r0.cross(r2), c12 = r1.cross(r2);
  const double n01 = c01.squaredNorm(), n02 = c02.squaredNorm(), n12 = c12.squaredNorm();
  Vec3d v = c01;
  double n = n01;
  if (n02 > n) {
    v = c02;
    n = n02;
  }
  if (n12 > n) {
    v = c12;
    n = n12;
  }
  if (!(n > 0.0) || !std::isfinite(n)) return smallest_by_jacobi(a);
  return v / std::sqrt(n);
}

}  // namespace v2xloc
