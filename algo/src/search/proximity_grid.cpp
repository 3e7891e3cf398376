#include "v2xloc/algo/search/proximity_grid.hpp"

#include <cmath>

#include "v2xloc/algo/core/finite.hpp"

namespace v2xloc {
namespace {

// Marking slack in cells: far above the < 2^-28 rounding of a cell coordinate (header proof),
// far below a cell, so only points within 1e-6 cells of a face mark a second cell.
constexpr double kSlack = 1.0 / 1048576.0;  // 2^-20

// OR of x shifted up (towards higher x) by 0..r bits, in doubling steps (<= 6 for r <= 63).
std::uint64_t smear_up(std::uint64_t x, std::uint32_t r) {
  for (std::uint32_t covered = 0; covered < r;) {
    const std::uint32_t b = covered + 1 < r - covered ? covered + 1 : r - covered;
    x |= x << b;
    covered += b;
  }
  return x;
}

std::uint64_t smear_down(std::uint64_t x, std::uint32_t r) {
  for (std::uint32_t covered = 0; covered < r;) {
    const std::uint32_t b = covered + 1 < r - covered ? covered + 1 : r - covered;
    x |= x >> b;
    covered += b;
  }
  return x;
}

}  // namespace

void ProximityGrid::begin(std::span<const Vec3f> map_points, const Vec3d& center,
                          const Vec3d& half_extent, const ProximityGridParams& params) {
  points_ = map_points;
  for (int a = 0; a < 3; ++a) limit_[a] = 0.0;
  cells_x_ = cells_y_ = 0;
  total_work_ = work_done_ = cursor_ = carry_ = 0;
  marked_ = outside_ = non_finite_ = 0;
  pass_ = passes_ = r_ = 0;
  dims_[0] = dims_[1] = dims_[2] = 0;
  total_words_ = row_words_ = plane_words_ = 0;
  cell_ = inv_cell_ = 0.0;
  reach_ = 0.0;
  phase_ = Phase::kDone;
  valid_ = false;
  const double reach = params.reach;
  if (!is_finite_point(center) || !is_finite_point(half_extent) || !(half_extent.minCoeff() >= 0.0) ||
      !(params.cell > 0.0f) || !std::isfinite(params.cell) || !(reach >= 0.0) ||
      !std::isfinite(reach)) {
    return;
  }
  // Smallest cell of the sequence cell * (9/8)^k that fits: at most 12.5 % coarser than needed.
  double cell = params.cell;
  bool fits = false;
  for (std::uint32_t k = 0; k < kMaxGrowthSteps && std::isfinite(cell); ++k, cell *= 1.125) {
    if (fit(cell, reach, half_extent)) {
      fits = true;
      break;
    }
  }
  if (!fits) return;
  reach_ = reach;
  cell_ = cell;
  inv_cell_ = 1.0 / cell;
  for (int a = 0; a < 3; ++a) origin_[a] = center[a] - half_extent[a] - static_cast<double>(r_) * cell;
  row_words_ = (dims_[0] + 63u) / 64u;
  plane_words_ = row_words_ * dims_[1];
  total_words_ = plane_words_ * dims_[2];
  last_mask_ = dims_[0] % 64u == 0 ? ~std::uint64_t{0} : (std::uint64_t{1} << (dims_[0] % 64u)) - 1u;
  passes_ = 0;
  for (std::uint32_t covered = 0; covered < r_; ++passes_) {
    const std::uint32_t b = covered + 1 < r_ - covered ? covered + 1 : r_ - covered;
    shifts_[passes_] = static_cast<std::uint8_t>(b);
    covered += b;
  }
  const std::uint64_t words = total_words_;
  total_work_ = words + points_.size() + (r_ > 0 ? words * (1u + 4u * passes_) : 0u);
  valid_ = true;
  phase_ = Phase::kClear;
}

// Sets r_ and dims_ for this cell; false when r or the words exceed the limits.
bool ProximityGrid::fit(double cell, double reach, const Vec3d& half_extent) {
  double r = std::ceil(reach / cell);
  if (r * cell < reach) r += 1.0;  // the division rounded down onto an integer
  if (!(r <= kMaxReachCells)) return false;
  // No axis fits more than 64 * capacity cells; the bound also keeps the conversions in range.
  const double max_cells = 64.0 * static_cast<double>(kCapacityWords);
  std::uint64_t n[3];
  for (int a = 0; a < 3; ++a) {
    double cells = std::ceil(2.0 * half_extent[a] / cell) + 2.0 * r;
    if (cells < 1.0) cells = 1.0;
    if (!(cells <= max_cells)) return false;
    n[a] = static_cast<std::uint64_t>(cells);
  }
  if (((n[0] + 63u) / 64u) * n[1] * n[2] > kCapacityWords) return false;
  r_ = static_cast<std::uint32_t>(r);
  for (int a = 0; a < 3; ++a) dims_[a] = static_cast<std::uint32_t>(n[a]);
  return true;
}

bool ProximityGrid::step(std::uint64_t budget) {
  // Each turn runs a phase to its end, spends the rest of the budget, or opens the next phase:
  // <= 2 (3 + 4m) + 1 turns.
  while (phase_ != Phase::kDone) {
    const std::uint64_t length = phase_length();
    if (cursor_ >= length) {
      advance();
      continue;
    }
    if (budget == 0) break;
    const std::uint64_t n = budget < length - cursor_ ? budget : length - cursor_;
    run(cursor_, cursor_ + n);
    cursor_ += n;
    budget -= n;
    work_done_ += n;
  }
  return ready();
}

void ProximityGrid::build(std::span<const Vec3f> map_points, const Vec3d& center,
                          const Vec3d& half_extent, const ProximityGridParams& params) {
  begin(map_points, center, half_extent, params);
  step(~std::uint64_t{0});
}

std::uint64_t ProximityGrid::phase_length() const {
  return phase_ == Phase::kMark ? points_.size() : total_words_;
}

void ProximityGrid::advance() {
  cursor_ = 0;
  switch (phase_) {
    case Phase::kClear: phase_ = Phase::kMark; return;
    case Phase::kMark: phase_ = r_ > 0 ? Phase::kDilateX : Phase::kDone; break;
    case Phase::kDilateX: phase_ = Phase::kDilateY; pass_ = 0; return;
    case Phase::kDilateY:
      if (++pass_ == 2 * passes_) {
        phase_ = Phase::kDilateZ;
        pass_ = 0;
      }
      return;
    case Phase::kDilateZ:
      if (++pass_ == 2 * passes_) phase_ = Phase::kDone;
      break;
    case Phase::kDone: break;
  }
  if (phase_ == Phase::kDone) {  // open the queries
    for (int a = 0; a < 3; ++a) limit_[a] = static_cast<double>(dims_[a]);
    cells_x_ = dims_[0];
    cells_y_ = dims_[1];
  }
}

void ProximityGrid::run(std::uint64_t from, std::uint64_t to) {
  // Passes 0 .. m-1 OR in the row b ahead (ascending), m .. 2m-1 the row b behind (descending).
  const bool ascending = pass_ < passes_;
  const std::uint64_t b = shifts_[ascending ? pass_ : pass_ - passes_];
  switch (phase_) {
    case Phase::kClear:
      for (std::uint64_t i = from; i < to; ++i) words_[i] = 0;
      break;
    case Phase::kMark: mark(from, to); break;
    case Phase::kDilateX: dilate_x(from, to); break;
    case Phase::kDilateY: dilate_rows(from, to, plane_words_, b * row_words_, ascending); break;
    case Phase::kDilateZ: dilate_rows(from, to, total_words_, b * plane_words_, ascending); break;
    case Phase::kDone: break;
  }
}

void ProximityGrid::mark(std::uint64_t from, std::uint64_t to) {
  for (std::uint64_t i = from; i < to; ++i) {
    const Vec3f& p = points_[i];
    if (!is_finite_point(p)) {
      ++non_finite_;
      continue;
    }
    std::uint32_t lo[3], hi[3];
    bool inside = true;
    for (int a = 0; a < 3 && inside; ++a) {
      const double u = (static_cast<double>(p[a]) - origin_[a]) * inv_cell_;
      const double first = u - kSlack, last = u + kSlack;
      const double n = static_cast<double>(dims_[a]);
      // floor(last) >= 0 and floor(first) < n; clipped, both are >= 0, where truncation is floor.
      inside = last >= 0.0 && first < n;
      if (!inside) break;
      lo[a] = first < 0.0 ? 0u : static_cast<std::uint32_t>(first);
      hi[a] = last >= n ? dims_[a] - 1u : static_cast<std::uint32_t>(last);
    }
    if (!inside) {
      ++outside_;
      continue;
    }
    ++marked_;
    if (lo[0] == hi[0] && lo[1] == hi[1] && lo[2] == hi[2]) {  // all but points on a face
      words_[lo[2] * plane_words_ + lo[1] * row_words_ + (lo[0] >> 6u)] |= std::uint64_t{1} << (lo[0] & 63u);
      continue;
    }
    for (std::uint32_t z = lo[2]; z <= hi[2]; ++z) {
      for (std::uint32_t y = lo[1]; y <= hi[1]; ++y) {
        for (std::uint32_t x = lo[0]; x <= hi[0]; ++x) {
          words_[z * plane_words_ + y * row_words_ + (x >> 6u)] |= std::uint64_t{1} << (x & 63u);
        }
      }
    }
  }
}

// Each word becomes the OR of its bits shifted by -r..r, bits crossing into it from the row's
// neighbouring words included (r < 64: only the adjacent ones). In place, ascending: the next
// word is still original, the previous one is kept in carry_ before it is overwritten.
void ProximityGrid::dilate_x(std::uint64_t from, std::uint64_t to) {
  const std::uint32_t r = r_;
  std::uint64_t j = from % row_words_;  // word within its row
  for (std::uint64_t i = from; i < to; ++i) {
    const std::uint64_t cur = words_[i];
    std::uint64_t out = smear_up(cur, r) | smear_down(cur, r);
    // Bits of the previous word shifted up by d in 1..r land at d - 64 + bit (and mirrored).
    if (j > 0) out |= smear_down(carry_ >> (64u - r), r - 1u);
    if (j + 1 < row_words_) {
      out |= smear_up(words_[i + 1] << (64u - r), r - 1u);
    } else {
      out &= last_mask_;  // cells past nx stay clear
    }
    carry_ = cur;
    words_[i] = out;
    j = j + 1 == row_words_ ? 0 : j + 1;
  }
}

// One in-place pass over blocks of `block` words (a z plane for y, the grid for z): word k of a
// block ORs in word k + stride (ascending; still original when read) or k - stride
// (descending: positions run from the block's end). Words without a partner are visited, unchanged.
void ProximityGrid::dilate_rows(std::uint64_t from, std::uint64_t to, std::uint64_t block,
                                std::uint64_t stride, bool ascending) {
  std::uint64_t pos = from;
  while (pos < to) {  // one block per turn
    const std::uint64_t base = pos / block * block;
    const std::uint64_t k0 = pos - base;
    const std::uint64_t k1 = to - base < block ? to - base : block;
    std::uint64_t* w = words_ + base;
    if (ascending) {
      const std::uint64_t end = block > stride ? block - stride : 0;
      for (std::uint64_t k = k0; k < k1 && k < end; ++k) w[k] |= w[k + stride];
    } else {
      for (std::uint64_t k = k0; k < k1; ++k) {
        const std::uint64_t at = block - 1 - k;
        if (at < stride) break;
        w[at] |= w[at - stride];
      }
    }
    pos = base + k1;
  }
}

}  // namespace v2xloc
