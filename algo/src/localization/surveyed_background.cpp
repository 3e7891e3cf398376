#include "v2xloc/algo/localization/surveyed_background.hpp"

#include <algorithm>

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

// First index with keys[i] >= k (n when none); log2(n) + 1 halvings.
std::size_t lower_bound(std::span<const std::uint32_t> keys, std::uint32_t k) {
  std::size_t lo = 0, n = keys.size();
  while (n > 0) {
    const std::size_t half = n / 2;
    if (keys[lo + half] < k) {
      lo += half + 1;
      n -= half + 1;
    } else {
      n = half;
    }
  }
  return lo;
}

// p's own cell is a background cell (outside the key span: off the background).
bool on_background(std::span<const std::uint32_t> keys, const Vec3f& p, double inv_cell) {
  std::int32_t c[3];
  if (!cell_of(p, inv_cell, c)) return false;
  const std::uint32_t key = pack(c[0], c[1], c[2]);
  const std::size_t i = lower_bound(keys, key);
  return i < keys.size() && keys[i] == key;
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
  const std::size_t cap = std::clamp<std::size_t>(params.max_points, 1, config::kBackgroundCheckPoints);
  const std::size_t stride = std::max<std::size_t>(1, (points.size() + cap - 1) / cap);
  // Zero offset, over every sampled finite point (exact: it is the reported fitness).
  std::uint32_t hits = 0;
  for (std::size_t i = 0; i < points.size(); i += stride) {
    if (!points[i].allFinite()) continue;
    ++s.sampled;
    hits += on_background(b.cells, points[i], inv_cell) ? 1u : 0u;
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
          if (on_background(b.cells, points[i] + o, inv_cell)) {
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
