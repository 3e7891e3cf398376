// Map normals computed on first use instead of for every map point at build time. Point-to-plane
// ICP needs the normal of a map point only once some source point matches it, and a tracked frame
// matches a few thousand of a map's ~60k points: computing all of them (~4k instructions each)
// made the first map build ~150 M instructions and kept a rebuild busy for ~30 periods. Each
// normal is exactly what estimate_normals() gives for that point (same neighbourhood, same bits),
// so results do not depend on when it was computed. Work per period is capped (new_period's
// quota): past it, get() answers NaN (the ICP skips that pair) and the refusal is counted.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/search/kdtree.hpp"

namespace v2xloc {

struct LazyNormalCounters {
  std::uint32_t computed = 0;  // this period
  std::uint32_t refused = 0;   // this period, quota spent: answered NaN (never silent)
};

class LazyNormals {
 public:
  // tree over the points whose normals are asked; storage >= points, done_bits >= ceil(points / 64).
  // Clears the done bits (points / 64 words) and starts a period with `quota` (see new_period).
  void reset(const KdTree<Vec3f>* tree, const NormalParams& params, std::span<Vec3f> storage,
             std::span<std::uint64_t> done_bits, std::uint32_t quota);
  // A new period: at most `quota` normals computed until the next call (0: no limit). Returns
  // the ending period's {computed, refused}.
  LazyNormalCounters new_period(std::uint32_t quota);
  LazyNormalCounters this_period() const { return counters_; }  // so far in the current period
  // The normal of point i: computed now unless done; NaN when the quota is spent or i is out of range.
  Vec3f get(std::uint32_t i);

 private:
  const KdTree<Vec3f>* tree_ = nullptr;
  NormalParams params_{};
  std::span<Vec3f> normals_{};
  std::span<std::uint64_t> done_{};
  std::size_t points_ = 0;
  std::uint32_t quota_ = 0;
  LazyNormalCounters counters_{};
};

}  // namespace v2xloc
