// The one finite-point check of the core: every coordinate finite (no NaN, no +-Inf). For any
// fixed-size Eigen vector (Vec3f, Vec3d, Feature33): stages drop and count such points.
#pragma once

#include <cmath>

namespace v2xloc {

template <class Point>
bool is_finite_point(const Point& p) {
  for (int d = 0; d < Point::RowsAtCompileTime; ++d) {
    if (!std::isfinite(p[d])) return false;
  }
  return true;
}

}  // namespace v2xloc
