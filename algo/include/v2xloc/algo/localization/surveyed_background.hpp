// An infrastructure unit's surveyed static background, and the check of a cloud against it.
// Roadside LiDARs are fixed: at survey time their operator records the unit's empty scene (the
// background subtraction roadside LiDAR uses anyway), in the unit's own sensor frame. A genuine
// cloud falls into the background's cells wherever it was taken (traffic aside); a cloud whose
// points were moved under the unit's true pose does not, and no other unit is needed to see it:
// this is what a site with two units has in place of a quorum (map_fusion.hpp).
//
// The background is a set of voxel cells, as packed keys sorted ascending in caller-owned storage
// (the firmware loads them at start; algo/ only reads them). A cloud point is "on the background"
// when its own cell is a background cell (a binary search within one bucket of the sorted keys).
// The same sensor at the same pose fires the same rays, so a genuine point falls into the cells its
// ray's earlier returns filled, and the cells are a fingerprint of the ray pattern: even ground
// points, shifted along the ground, fall between the rings' cells. The check scores an even
// subsample of the cloud at zero offset (a floor) and displaced by world-axis probes (+-1, 2, 4
// probe steps along x, y, z, rotated into the sensor frame; a peak test): a genuine cloud scores
// high at zero and lower anywhere else; a moved one scores low at zero, and better at the probe
// that undoes a shift within the probes' reach. Measured on the 12 recordings: algo/TUNING.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

// Key layout: cell indices in offset binary, x and y 11 bits, z 10 bits: key = x << 21 | y << 10
// | z (sorted keys order cells by x, then y, then z). A key spans +-1024 cells horizontally and
// +-512 vertically: +-102 / +-51 m at 0.1 m cells, so a 100 m LiDAR fits at any cell >= 0.1 m.
inline constexpr std::int32_t kBackgroundHalfXY = 1024;
inline constexpr std::int32_t kBackgroundHalfZ = 512;
inline constexpr double kBackgroundMinCell = 0.02;  // [m] finer is noise, not geometry
inline constexpr double kBackgroundMaxCell = 2.0;   // [m] coarser cannot tell a 0.25 m shift

struct SurveyedBackground {
  double cell = 0.0;                       // [m] voxel edge
  std::span<const std::uint32_t> cells{};  // packed keys (background_cell_key), strictly ascending
};

// Packed key of p's cell; false when p is non-finite or outside the key's span.
bool background_cell_key(const Vec3f& p, double inv_cell, std::uint32_t& key);
// A usable background: cell in [kBackgroundMinCell, kBackgroundMaxCell], 1..kMaxBackgroundCells
// cells, strictly ascending (O(n), once when it is handed over).
bool background_valid(const SurveyedBackground& background);

struct BackgroundCheckParams {
  std::uint32_t max_points = config::kBackgroundCheckPoints;  // cloud points scored (even stride); clamped to the cap
  std::uint32_t min_points = 64;   // fewer finite points: no evidence the cloud is this unit's scene -> mismatch
  // Measured (12 recordings, 0.52 m cells, every infrastructure cloud): genuine 0.919-0.998 at
  // zero offset and every probe >= 0.158 lower; points moved 0.25 m east <= 0.820 with the probe
  // that undoes it >= 0.167 higher; moved 0.5-200 m <= 0.633. The floor sits between the
  // genuine and the 0.5 m+ scores, the peak test (margin 0) takes the shifts within the probes.
  double min_fitness = 0.85;       // fraction on the background at zero offset, at least
  double probe_margin = 0.0;       // no probe may score above fitness + margin
  double probe_step = 0.25;        // [m] probes at 1, 2, 4 steps
};

struct BackgroundScore {
  std::uint32_t sampled = 0;   // finite cloud points scored
  double fitness = 0.0;        // fraction of them on the background at zero offset
  double best_probe = 0.0;     // best fraction displaced by a probe (a lower bound once a probe cannot win)
  bool consistent = false;
};

// Scores `points` (the unit's cloud, sensor frame) against its background. sensor_R_world turns
// world-axis probe offsets into the sensor frame. Bounded: at most max_points x (1 + 18 probes)
// cell lookups (a bucketed binary search each); probes stop as soon as their verdict is decided.
BackgroundScore check_background(const SurveyedBackground& background, std::span<const Vec3f> points,
                                 const Mat3d& sensor_R_world, const BackgroundCheckParams& params);

}  // namespace v2xloc
