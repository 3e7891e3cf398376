// Gauss-Newton normal equations H = sum w J^T J accumulated on the lower triangle only (21 of 36
// products per residual): LDLT reads nothing else. mirror_lower() fills the upper triangle before
// anything reads the whole matrix. The lower triangle has the bits of the full outer product
// (w J_i) J_j, so results solved from it do not change.
#pragma once

#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

inline void add_weighted_outer_lower(Mat6d& h, double w, const Vec6d& j) {
  for (int r = 0; r < 6; ++r) {
    const double wr = w * j(r);
    for (int c = 0; c <= r; ++c) h(r, c) += wr * j(c);
  }
}

inline void mirror_lower(Mat6d& h) {
  for (int r = 0; r < 6; ++r) {
    for (int c = r + 1; c < 6; ++c) h(r, c) = h(c, r);
  }
}

}  // namespace v2xloc
