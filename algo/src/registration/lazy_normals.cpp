#include "v2xloc/algo/registration/lazy_normals.hpp"

#include <limits>

namespace v2xloc {

void LazyNormals::reset(const KdTree<Vec3f>* tree, const NormalParams& params, std::span<Vec3f> storage,
                        std::span<std::uint64_t> done_bits, std::uint32_t quota) {
  tree_ = tree;
  quota_ = quota;
  params_ = params;
  normals_ = storage;
  done_ = done_bits;
  counters_ = {};
  points_ = tree != nullptr ? tree->points().size() : 0;
  if (points_ > normals_.size()) points_ = normals_.size();
  if (points_ > done_.size() * 64) points_ = done_.size() * 64;
  for (std::size_t w = 0; w < (points_ + 63) / 64; ++w) done_[w] = 0;
}

LazyNormalCounters LazyNormals::new_period(std::uint32_t quota) {
  quota_ = quota;
  const LazyNormalCounters ended = counters_;
  counters_ = {};
  return ended;
}

Vec3f LazyNormals::get(std::uint32_t i) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  if (i >= points_) return Vec3f::Constant(kNaN);
  std::uint64_t& word = done_[i / 64];
  const std::uint64_t bit = std::uint64_t{1} << (i % 64);
  if ((word & bit) != 0) return normals_[i];
  if (quota_ > 0 && counters_.computed >= quota_) {
    ++counters_.refused;
    return Vec3f::Constant(kNaN);
  }
  estimate_normals_range(*tree_, params_, i, 1, normals_);
  word |= bit;
  ++counters_.computed;
  return normals_[i];
}

}  // namespace v2xloc
