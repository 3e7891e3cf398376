// The one symmetric eigen solver of the core: cyclic Jacobi (Golub & Van Loan, "Matrix
// Computations", Alg. 8.5.3). Rotations from +, -, *, /, sqrt only, in a fixed order: the same
// bits on every ISA. Used for 3x3 covariances (normals, registration degeneracy), the 6x6
// preconditioned ICP information and the 33x33 FPFH feature covariance; callers pick the
// scalar, the size, the sweep cap and the convergence test.
#pragma once

#include <cmath>

#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

// One cyclic sweep over the strictly upper triangle of the symmetric N x N matrix `a` (any type
// with a(i, j) access), each (p, q) rotated to zero: A <- J^T A J with J the (p, q) rotation
// [c s; -s c]. The rotations accumulate into `v` (eigenvectors as columns) when it is not null.
template <class Scalar, int N, class MatA, class MatV>
void jacobi_sweep(MatA& a, MatV* v) {
  for (int p = 0; p < N - 1; ++p) {
    for (int q = p + 1; q < N; ++q) {
      const Scalar apq = a(p, q);
      if (apq == Scalar(0)) continue;
      // tan(2 phi) = 2 a_pq / (a_qq - a_pp); t = tan(phi), the smaller root (G&VL 8.5.2).
      const Scalar theta = (a(q, q) - a(p, p)) / (Scalar(2) * apq);
      const Scalar t = (theta >= Scalar(0) ? Scalar(1) : Scalar(-1)) /
                       (std::abs(theta) + std::sqrt(theta * theta + Scalar(1)));
      const Scalar c = Scalar(1) / std::sqrt(t * t + Scalar(1));
      const Scalar s = t * c;
      for (int k = 0; k < N; ++k) {  // columns p, q
        const Scalar akp = a(k, p), akq = a(k, q);
        a(k, p) = c * akp - s * akq;
        a(k, q) = s * akp + c * akq;
      }
      for (int k = 0; k < N; ++k) {  // rows p, q
        const Scalar apk = a(p, k), aqk = a(q, k);
        a(p, k) = c * apk - s * aqk;
        a(q, k) = s * apk + c * aqk;
      }
      if (v == nullptr) continue;
      for (int k = 0; k < N; ++k) {
        const Scalar vkp = (*v)(k, p), vkq = (*v)(k, q);
        (*v)(k, p) = c * vkp - s * vkq;
        (*v)(k, q) = s * vkp + c * vkq;
      }
    }
  }
}

// Eigen decomposition of a symmetric 3x3: eigenvalues ascending (stable, by index on ties), the
// unit eigenvectors as the matching columns. At most config::kJacobiMaxSweeps sweeps.
void symmetric_eigen3(const Mat3d& a, Vec3d& eigenvalues, Mat3d& eigenvectors);

// The unit eigenvector of the smallest eigenvalue of a symmetric 3x3 (a surface normal) without
// iterating: the eigenvalues in closed form (Smith 1961, "Eigenvalues of a symmetric 3x3 matrix",
// CACM 4(4):168), then the longest column of adj(A - lambda_0 I) = (l1 - l0)(l2 - l0) v0 v0^T,
// i.e. the longest cross product of two rows of A - lambda_0 I. ~10x cheaper than the Jacobi
// sweeps. Its accuracy degrades as l1 - l0 shrinks: below 1e-3 (l2 - l0) (no plane to speak of),
// for a multiple of I and for non-finite input it falls back to symmetric_eigen3. The sign is
// whichever the cross product gives (point-to-plane residuals do not depend on it).
Vec3d smallest_eigenvector3(const Mat3d& a);

}  // namespace v2xloc
