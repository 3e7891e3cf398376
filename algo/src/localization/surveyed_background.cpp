#include "v2xloc/algo/localization/surveyed_background.hpp"

#include <algorithm>
#include <array>

#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc {

namespace {

constexpr std::int64_t kSpanXY = 2 * kBackgroundHalfXY;  // offset-binary index range per axis
constexpr std::int64_t kSpanZ = 2 * kBackgroundHalfZ;
static_assert(kSpanXY * kSpanXY * kSpanZ == (std::int64_t{1} << 32), "keys fill 32 bits");

// p's cell in offset binary; false when non-finite or outside the key's span.
bool cell_of(const Vec3f& p, double inv_cell, std::int32_t c[3]) {
  const std::int32_t half[3] = {kBackgroundHalfXY, kBackgroundHalfXY, kBackgroundHalfZ};
  for (int i = 0; i < 3; ++i) {
    const double q = static_cast<double>(p(i)) * inv_cell;
    if (!(q >= -half[i] && q < half[i])) return false;  // NaN fails here too
    c[i] = det::floor_to_int(q) + half[i];
  }
  return true;
}

std::uint32_t pack(std::int32_t x, std::int32_t y, std::int32_t z) {
  return (static_cast<std::uint32_t>(x) << 21) | (static_cast<std::uint32_t>(y) << 10) | static_cast<std::uint32_t>(z);
}

// The sorted keys cut into buckets of equal key range, so a lookup binary-searches one bucket
// (~10 keys on a unit's background: 3-4 halvings) instead of all of them (13-14). Built per check
// in O(keys + buckets), on the stack; the answers are those of a search over every key.
class KeyIndex {
 public:
  explicit KeyIndex(std::span<const std::uint32_t> keys) : keys_(keys) {
    if (keys.empty()) return;
    lo_ = keys.front();
    const std::uint32_t range = keys.back() - lo_;
    while (shift_ < 32 && (range >> shift_) >= kBuckets) ++shift_;
    std::size_t b = 0;
    for (std::size_t i = 0; i < keys.size(); ++i) {
      // Clamped: keys out of order (background_valid refuses them) cannot write past the table.
      const std::size_t bucket = std::min<std::size_t>((keys[i] - lo_) >> shift_, kBuckets - 1);
      while (b <= bucket) starts_[b++] = static_cast<std::uint32_t>(i);
    }
    while (b <= kBuckets) starts_[b++] = static_cast<std::uint32_t>(keys.size());
  }

  bool contains(std::uint32_t k) const {
    if (keys_.empty() || k < lo_ || k > keys_.back()) return false;
    const std::size_t bucket = (k - lo_) >> shift_;
    std::size_t lo = starts_[bucket], n = starts_[bucket + 1] - lo;
    while (n > 0) {  // first key >= k in the bucket
      const std::size_t half = n / 2;
      if (keys_[lo + half] < k) {
        lo += half + 1;
        n -= half + 1;
      } else {
        n = half;
      }
    }
    return lo < starts_[bucket + 1] && keys_[lo] == k;
  }

 private:
  static constexpr std::size_t kBuckets = 1024;
  std::span<const std::uint32_t> keys_;
  std::uint32_t lo_ = 0;
  std::uint32_t shift_ = 0;
  std::array<std::uint32_t, kBuckets + 1> starts_{};
};

// p's own cell is a background cell (outside the key span: off the background).
bool on_background(const KeyIndex& keys, const Vec3f& p, double inv_cell) {
  std::int32_t c[3];
  if (!cell_of(p, inv_cell, c)) return false;
  return keys.contains(pack(c[0], c[1], c[2]));
}

}  // namespace

bool background_cell_key(const Vec3f& p, double inv_cell, std::uint32_t& key) {
  std::int32_t c[3];
  if (!cell_of(p, inv_cell, c)) return false;
  key = pack(c[0], c[1], c[2]);
  return true;
}

bool background_valid(const SurveyedBackground& b) {
  if (!(b.cell >= kBackgroundMinCell && b.cell <= kBackgroundMaxCell)) return false;
  if (b.cells.empty() || b.cells.size() > config::kMaxBackgroundCells) return false;
  for (std::size_t i = 1; i < b.cells.size(); ++i) {
    if (!(b.cells[i - 1] < b.cells[i])) return false;
  }
  return true;
}

BackgroundScore check_background(const SurveyedBackground& b, std::span<const Vec3f> points,
                                 const Mat3d& sensor_R_world, const BackgroundCheckParams& params) {
  BackgroundScore s;
  if (!(b.cell > 0.0)) return s;  // not a background (background_valid): inconsistent
  const double inv_cell = 1.0 / b.cell;
  const KeyIndex keys(b.cells);
  const std::size_t cap = std::clamp<std::size_t>(params.max_points, 1, config::kBackgroundCheckPoints);
  const std::size_t stride = std::max<std::size_t>(1, (points.size() + cap - 1) / cap);
  // Zero offset, over every sampled finite point (exact: it is the reported fitness).
  std::uint32_t hits = 0;
  for (std::size_t i = 0; i < points.size(); i += stride) {
    if (!points[i].allFinite()) continue;
    ++s.sampled;
    hits += on_background(keys, points[i], inv_cell) ? 1u : 0u;
  }
  if (s.sampled < params.min_points) return s;  // too little to show the unit's scene
  s.fitness = static_cast<double>(hits) / s.sampled;
  if (s.fitness < params.min_fitness) return s;  // the scene is not where the unit is
  // Probes along the world axes, in the sensor frame; each stops once its verdict is decided.
  const double beat = s.fitness + params.probe_margin;
  const std::uint32_t total = s.sampled;
  for (const double steps : {1.0, 2.0, 4.0}) {
    for (int axis = 0; axis < 3; ++axis) {
      for (const double sign : {1.0, -1.0}) {
        const Vec3f o = (sensor_R_world.col(axis) * (sign * steps * params.probe_step)).cast<float>();
        std::uint32_t probe_hits = 0, misses = 0;
        for (std::size_t i = 0; i < points.size(); i += stride) {
          if (!points[i].allFinite()) continue;
          if (on_background(keys, points[i] + o, inv_cell)) {
            if (static_cast<double>(++probe_hits) / total > beat) break;  // already fits better
          } else if (static_cast<double>(total - ++misses) / total <= beat) {
            break;  // cannot beat the zero offset any more
          }
        }
        const double f = static_cast<double>(probe_hits) / total;
        s.best_probe = std::max(s.best_probe, f);
        if (f > beat) return s;  // fits better displaced: moved points
      }
    }
  }
  s.consistent = true;
  return s;
}

}  // namespace v2xloc
