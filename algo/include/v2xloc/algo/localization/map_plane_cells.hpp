// Local planes of one cloud on a cubic grid, for map fusion's consistency check: each occupied
// cell keeps its points' first and second moments; the plane (centroid, normal) is fitted the
// first time a query needs it, so only cells near the reference points pay the eigen solve.
// A query returns the planar cell of the 2 x 2 x 2 block nearest the point (its own cell and
// the neighbours on the sides it is closest to) with the smallest point-to-plane distance.
// Storage lives in the object (static only); cells beyond the table's probes are counted.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct PlaneMatch {
  bool found = false;
  Vec3d normal = Vec3d::Zero();
  double residual = 0.0;  // [m] signed distance of the query point to the plane
};

class MapPlaneCells {
 public:
  // Rebuilds the cells from `points`; cell_size [m]; a plane needs min_points points and a
  // smallest covariance eigenvalue <= max_flatness times the middle one, and the middle one
  // >= min_spread^2 (a patch, not a line). Returns cells dropped.
  std::uint32_t build(std::span<const Vec3f> points, double cell_size, std::uint32_t min_points,
                      double max_flatness, double min_spread);
  // Is the cell holding p occupied (any point)?
  bool occupied(const Vec3d& p) const;
  // Occupancy of the cell holding p: 0 empty, 1 level (its points' height spread is under a
  // tenth of their horizontal spread: ground, roofs), 2 anything else (walls, objects). No fit.
  int occupancy(const Vec3d& p) const;
  // Nearest plane (smallest |residual|) among the planar cells of the block around p.
  PlaneMatch nearest_plane(const Vec3d& p);
  std::uint32_t cells() const { return cells_; }

 private:
  struct Cell {
    std::int32_t key[3];
    std::uint32_t stamp;  // occupied iff stamp == stamp_
    std::uint32_t count;
    std::uint8_t fit;     // 0 not fitted yet, 1 planar, 2 not planar
    float sum[3];         // relative to the cell corner (small numbers: float is exact enough)
    float sq[6];          // xx xy xz yy yz zz, relative to the cell corner
    float centroid[3];    // relative to the cell corner, once fitted
    float normal[3];
  };
  static constexpr std::size_t kSlots = config::kMapCheckCellSlots;
  static_assert((kSlots & (kSlots - 1)) == 0, "plane cell slots must be a power of two");

  bool key_of(const Vec3d& p, std::int32_t key[3]) const;
  Cell* find(const std::int32_t key[3]);
  const Cell* find(const std::int32_t key[3]) const;
  Cell* find_or_add(const std::int32_t key[3]);
  void fit(Cell& c) const;

  Cell cells_table_[kSlots] = {};
  std::uint32_t stamp_ = 0;
  std::uint32_t cells_ = 0;
  double cell_size_ = 1.0;
  std::uint32_t min_points_ = 5;
  double max_flatness_ = 0.1;
  double min_spread_ = 0.1;
};

}  // namespace v2xloc
