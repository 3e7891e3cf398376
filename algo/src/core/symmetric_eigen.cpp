#include "v2xloc/algo/core/symmetric_eigen.hpp"

#include <utility>

#include "v2xloc/algo/core/config.hpp"

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

}  // namespace v2xloc
