// Uniform random points in [-scale, scale]^D (3-D points or 33-D features) for the k-d tree tests.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

namespace v2xloc::test {

template <class P>
std::vector<P> random_points(std::size_t n, std::uint32_t seed, float scale) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-scale, scale);
  std::vector<P> pts(n);
  for (auto& p : pts) {
    for (int d = 0; d < P::RowsAtCompileTime; ++d) p[d] = u(rng);
  }
  return pts;
}

}  // namespace v2xloc::test
