// "Is there a map point near q?" in O(1): a 3-D bitmap over an axis-aligned box, one bit per
// cell, set where a map point lies within a cube of +-r cells. Pose-search hypothesis scoring
// asks this of ~100 points per hypothesis; a k-d tree's any_within answers it exactly in
// ~500-1100 instructions, near() in ~35 (x86-64, measured with callgrind).
//
// Geometry. begin() takes the box B = [center - half_extent, center + half_extent], a cell edge
// c and a reach. r = ceil(reach / c) (checked: r * c >= reach). The grid covers B padded by r
// cells on every side, so map points just outside B still count for queries inside B; n cells
// per axis, origin o = center - half_extent - r c. If the cells do not fit in
// config::kProximityGridWords words (x rows of ceil(nx / 64) words, then y, then z), or r would
// exceed kMaxReachCells, c grows by 9/8 steps until they do: cell() is the cell used. Layout:
// bit (ix & 63) of word (iz ny + iy) ceil(nx / 64) + ix / 64.
//
// Semantics, with u(x) = (x - o) / c the exact cell coordinate along an axis and u^ its double
// evaluation (|u^ - u| < 2^-28 for any |u| < 2^23, i.e. the whole grid: three roundings of
// 2^-53 relative; the rounding of o and of r c against reach stay below 2^-28 cells while
// |center| / c < 2^24). A map point p marks, per axis, the cells floor(u^(p) - s) ..
// floor(u^(p) + s) (one cell, two when p sits within s = 2^-20 cells of a cell face); dilation
// ORs every marked cell into the cube of +-r cells around it; near(q) reads the bit of cell
// floor(u^(q)).
//  - No false negative: if |q - p| <= reach for a map point p and q lies in B, near(q) is true.
//    Per axis |u(q) - u(p)| <= reach / c <= r (+ 2^-46), so
//      u^(q) <= u(q) + 2^-28 <= u(p) + r + 2^-27 <= u^(p) + r + 3 * 2^-28 < u^(p) + s + r,
//    and floor(x + r) = floor(x) + r with floor monotone gives floor(u^(q)) <= floor(u^(p) + s)
//    + r; likewise floor(u^(q)) >= floor(u^(p) - s) - r: on every axis q's cell is within r of
//    p's marked range. Boundary cases (reach 2, c 1, o 0): p at 0.99 and q at 2.98, or p at
//    0.01 (or 0.0) and q at 2.0, are in cells 0 and 2: index difference r, near. Rounding alone
//    could break this at distance == reach: u^(p) may land on a face (u(p) = 5 - 2^-51
//    evaluates to 5.0, one cell past p's own), which s absorbs by marking both cells. q in B
//    means u(q) in [r, n - r], so p's range meets the grid (clipping it keeps the property).
//  - Bounded false positives: near(q) means some map point p has, on every axis,
//    |u(q) - u(p)| < r + 1 + 2^-19, i.e. |q - p| < (r + 1 + 2^-19) c per axis and
//    < (r + 1 + 2^-19) c sqrt(3) in Euclidean distance.
//  - Outside the grid, non-finite queries, before ready(), and for an invalid grid: false.
//
// Build, incremental and deterministic: begin() does no per-point or per-word work (its growth
// loop runs <= kMaxGrowthSteps times); each step(budget) does at most budget work units and
// returns ready(). A unit is one word cleared, one map point marked (1-8 bits), or one word
// position visited by a dilation pass. Phases: clear the used words; mark the points (non-finite
// and off-grid ones counted, not marked); dilate x (one pass, bit shifts across a row's words;
// the previous word's original value is the only carried state); then y, then z, each as
// m = ceil(log2(r + 1)) passes "row |= row b ahead" (ascending) and m "row |= row b behind"
// (descending), b = 1, 2, 4, ... with the last cut so they sum to r (r = 2: 1, 1). Each pass
// reads only rows it has not written yet, so the passes work in place and together OR each row
// with its +-r neighbours: no scratch memory, the object is the bitmap plus ~150 bytes.
// total_work() = W (2 + 4m) + N for r > 0, W + N for r = 0 (W = words_used(), N = map points),
// <= N + 26 kProximityGridWords; with budget >= 1 the grid is ready after
// ceil(total_work() / budget) step() calls. Sliced builds give the same bits as build().
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct ProximityGridParams {
  float cell = 1.0f;   // requested cell edge [m]; grown when the box does not fit
  float reach = 2.0f;  // [m]: near(q) is true whenever a map point lies within reach of q
};

class ProximityGrid {
 public:
  static constexpr std::size_t kCapacityWords = config::kProximityGridWords;
  // The x dilation shifts bits into the adjacent word only: r < 64.
  static constexpr std::uint32_t kMaxReachCells = 63;
  // 9/8 growth steps tried before the box is rejected (a factor of 2^174 over the request).
  static constexpr std::uint32_t kMaxGrowthSteps = 1024;
  static_assert(kCapacityWords >= 9 && kCapacityWords <= (std::size_t{1} << 16),
                "cell indices must stay below 2^22 for the rounding bound in the header");

  // map_points must stay alive and unchanged until ready(). Invalid input (non-finite center or
  // extent, negative extent, cell <= 0, reach < 0, or a box no growth fits): ready() at once,
  // valid() false, every query false.
  void begin(std::span<const Vec3f> map_points, const Vec3d& center, const Vec3d& half_extent,
             const ProximityGridParams& params = {});
  // At most `budget` work units (see above); budget 0 does nothing. Returns ready().
  bool step(std::uint64_t budget);
  void build(std::span<const Vec3f> map_points, const Vec3d& center, const Vec3d& half_extent,
             const ProximityGridParams& params = {});

  bool ready() const { return phase_ == Phase::kDone; }
  bool valid() const { return valid_; }

  // Inline: the scoring loop calls it ~7.5k hypotheses x ~100 points. The limits stay 0 until
  // the build is done, so a half-built grid answers false; NaN fails every comparison.
  bool near(const Vec3f& q) const {
    const double ux = (static_cast<double>(q.x()) - origin_[0]) * inv_cell_;
    const double uy = (static_cast<double>(q.y()) - origin_[1]) * inv_cell_;
    const double uz = (static_cast<double>(q.z()) - origin_[2]) * inv_cell_;
    if (!(ux >= 0.0 && ux < limit_[0] && uy >= 0.0 && uy < limit_[1] && uz >= 0.0 &&
          uz < limit_[2])) {
      return false;
    }
    // Truncation is floor for u >= 0.
    const auto ix = static_cast<std::uint32_t>(ux);
    const auto iy = static_cast<std::uint32_t>(uy);
    const auto iz = static_cast<std::uint32_t>(uz);
    const std::uint64_t word = words_[iz * plane_words_ + iy * row_words_ + (ix >> 6u)];
    return ((word >> (ix & 63u)) & 1u) != 0;
  }

  // For many queries at one height (the pose search's hypotheses share the road height): the
  // word offset of qz's cell plane, -1 outside the grid (or before ready()), for near_cell.
  std::int64_t plane_offset(float qz) const {
    const double uz = (static_cast<double>(qz) - origin_[2]) * inv_cell_;
    if (!(uz >= 0.0 && uz < limit_[2])) return -1;
    return static_cast<std::int64_t>(static_cast<std::uint32_t>(uz) * plane_words_);
  }
  // Queries that move over a lattice of whole cells (the pose search's hypotheses, a grid step
  // apart): the cell of (x, y) as integers, floor, possibly outside the grid ...
  void cell_xy(double x, double y, std::int64_t& ix, std::int64_t& iy) const {
    constexpr double kFar = 1e9;  // [cells] clamp: far outside is outside, and no overflow
    double ux = std::floor((x - origin_[0]) * inv_cell_), uy = std::floor((y - origin_[1]) * inv_cell_);
    ux = ux > kFar ? kFar : (ux < -kFar || !(ux == ux) ? -kFar : ux);
    uy = uy > kFar ? kFar : (uy < -kFar || !(uy == uy) ? -kFar : uy);
    ix = static_cast<std::int64_t>(ux);
    iy = static_cast<std::int64_t>(uy);
  }
  // ... then near() of a point in cell (ix, iy) at the plane's height.
  bool near_cell(std::int64_t ix, std::int64_t iy, std::int64_t plane) const {
    // Negative indices wrap to huge unsigned ones: one compare per axis.
    if (plane < 0 || static_cast<std::uint64_t>(ix) >= cells_x_ || static_cast<std::uint64_t>(iy) >= cells_y_) return false;
    const auto x = static_cast<std::uint32_t>(ix);
    const std::uint64_t word = words_[static_cast<std::uint32_t>(plane) + static_cast<std::uint32_t>(iy) * row_words_ + (x >> 6u)];
    return ((word >> (x & 63u)) & 1u) != 0;
  }

  // The part of the grid where near() has no false negative (u(q) in [r, n - r] on every axis,
  // shrunk by 2^-20 cells for rounding): there, !near(q) proves that no map point lies within
  // reach of q. False before ready() and for non-finite queries.
  bool covers(const Vec3f& q) const {
    constexpr double kSlack = 1.0 / 1048576.0;
    const double lo = static_cast<double>(r_) + kSlack;
    const double u[3] = {(static_cast<double>(q.x()) - origin_[0]) * inv_cell_,
                         (static_cast<double>(q.y()) - origin_[1]) * inv_cell_,
                         (static_cast<double>(q.z()) - origin_[2]) * inv_cell_};
    for (int a = 0; a < 3; ++a) {
      if (!(u[a] >= lo && u[a] <= limit_[a] - lo)) return false;
    }
    return true;
  }
  // No map point within reach of q, proven (covers(q) and !near(q)); false: maybe one.
  bool none_within_reach(const Vec3f& q) const { return covers(q) && !near(q); }

  double cell() const { return cell_; }               // used cell edge [m] (>= requested)
  double reach() const { return reach_; }             // [m] as requested
  std::uint32_t reach_cells() const { return r_; }     // r
  std::uint32_t nx() const { return dims_[0]; }
  std::uint32_t ny() const { return dims_[1]; }
  std::uint32_t nz() const { return dims_[2]; }
  Vec3d origin() const { return {origin_[0], origin_[1], origin_[2]}; }  // corner of cell 0
  std::size_t words_used() const { return total_words_; }
  std::span<const std::uint64_t> words() const { return {words_, total_words_}; }
  std::uint32_t points_marked() const { return marked_; }
  std::uint32_t points_outside() const { return outside_; }       // finite, off the grid
  std::uint32_t points_non_finite() const { return non_finite_; }
  std::uint64_t total_work() const { return total_work_; }
  std::uint64_t work_done() const { return work_done_; }

 private:
  enum class Phase : std::uint8_t { kClear, kMark, kDilateX, kDilateY, kDilateZ, kDone };
  static constexpr std::uint32_t kMaxPasses = 6;  // ceil(log2(kMaxReachCells + 1))

  bool fit(double cell, double reach, const Vec3d& half_extent);
  std::uint64_t phase_length() const;
  void advance();
  void run(std::uint64_t from, std::uint64_t to);
  void mark(std::uint64_t from, std::uint64_t to);
  void dilate_x(std::uint64_t from, std::uint64_t to);
  void dilate_rows(std::uint64_t from, std::uint64_t to, std::uint64_t block, std::uint64_t stride,
                   bool ascending);

  std::uint64_t words_[kCapacityWords];
  std::span<const Vec3f> points_{};
  double origin_[3] = {0.0, 0.0, 0.0};
  double inv_cell_ = 0.0;
  double limit_[3] = {0.0, 0.0, 0.0};  // query bounds in cells: dims once ready, else 0
  std::uint64_t cells_x_ = 0, cells_y_ = 0;  // the same as integers (near_cell)
  double cell_ = 0.0;
  double reach_ = 0.0;
  std::uint64_t total_work_ = 0;
  std::uint64_t work_done_ = 0;
  std::uint64_t cursor_ = 0;           // position inside the current phase / pass
  std::uint64_t carry_ = 0;            // x dilation: original value of the previous word
  std::uint64_t last_mask_ = 0;        // valid bits of a row's last word
  std::uint32_t dims_[3] = {0, 0, 0};
  std::uint32_t row_words_ = 0;
  std::uint32_t plane_words_ = 0;
  std::uint32_t total_words_ = 0;
  std::uint32_t r_ = 0;
  std::uint32_t passes_ = 0;           // m: one-sided passes per direction and axis
  std::uint32_t pass_ = 0;             // current pass of the y / z phase, 0 .. 2m - 1
  std::uint32_t marked_ = 0;
  std::uint32_t outside_ = 0;
  std::uint32_t non_finite_ = 0;
  std::uint8_t shifts_[kMaxPasses] = {0, 0, 0, 0, 0, 0};  // b of each pass
  Phase phase_ = Phase::kDone;
  bool valid_ = false;
};

}  // namespace v2xloc
