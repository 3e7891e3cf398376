// Basin climb: the pose search's kept hypotheses moved to the bottom of their basins before they
// are compared. The search scores thousands of hypotheses on a coarse lattice (3 m, 15 deg) with a
// few score points; a hypothesis then sits up to ~2 m from its basin's bottom, where the true
// basin can score below an alias 20 m along a street canyon (its lattice point happens to lie
// nearer its own bottom). Compared at their bottoms, on more points, the truth wins by a margin
// (algo/TUNING.md, "Basin climb"). Each climb is a bounded hill climb in x and y, one step to the
// best of the 8 neighbours a `step` away, heading kept (the coarse ICP pulls in half a lattice
// heading), scored as the search scores: the fraction of above-ground points with a map point
// near (the proximity grid, else the k-d tree within score_distance).
// Work: climb_pose <= (1 + 8 rounds) points lookups; rank_basins O(n^2), n <= a few tens.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

class ProximityGrid;
template <typename Point>
class KdTree;

struct PoseSearchCandidate {
  double score = -1.0;  // [0-1] fraction of score points near the map; < 0: empty slot
  double x = 0.0, y = 0.0, yaw = 0.0;
};

inline constexpr std::uint32_t kMaxClimbPoints = 512;  // [points] scored per climb position
inline constexpr std::uint32_t kMaxClimbRounds = 16;    // [moves] per hypothesis

// A climb's points, rotated by its heading and lifted to the road once: every position it tries
// only adds its x and y (in double, as climb_score computes them, so both give the same bits).
struct ClimbPoint {
  double x = 0.0, y = 0.0;
  float z = 0.0f;
};
// The caller's scratch for climbs (12 KiB): each call fills it anew, nothing is kept between calls.
struct ClimbScratch {
  ClimbPoint points[kMaxClimbPoints];
};

struct BasinClimbParams {
  std::uint32_t points = 256;   // [points] above-ground scan points scored (<= kMaxClimbPoints)
  std::uint32_t rounds = 4;     // [moves] at most (<= kMaxClimbRounds)
  double step = 1.0;            // [m] a move: one proximity-grid cell keeps the grid's resolution
  double min_height = 0.5;      // [m] body-frame points below this are ground: not scored
  double score_distance = 2.0;  // [m] hit radius on the k-d tree (no grid)
  double ground_z = 0.0;        // [m] the hypotheses' road height
};

// What a climb looks at: the scan (body frame), and the map as a proximity grid (preferred, ready
// and valid) or its k-d tree.
struct ClimbTarget {
  std::span<const Vec3f> scan_body;
  const ProximityGrid* grid = nullptr;
  const KdTree<Vec3f>* tree = nullptr;
};

// The work a climb did: points looked up, and the k-d tree nodes they visited (no grid).
struct ClimbWork {
  std::uint64_t lookups = 0;
  std::uint64_t node_visits = 0;
};

// Score of one pose on an even subsample of at most params.points above-ground points; -1 when
// no point qualifies or there is no map. scratch: the rotated points.
double climb_score(const ClimbTarget& target, double x, double y, double yaw, const BasinClimbParams& params,
                   ClimbScratch& scratch, ClimbWork* work = nullptr);

// Rescores h on the subsample, then moves it to its best neighbour while that scores higher, at
// most params.rounds moves. h.score becomes the climbed score (comparable between climbs only).
void climb_pose(const ClimbTarget& target, PoseSearchCandidate& h, const BasinClimbParams& params,
                ClimbScratch& scratch, ClimbWork* work = nullptr);

// Orders climbed hypotheses best first, each basin's best ahead of the rest: a hypothesis within
// basin_distance and basin_yaw of a better leader follows all the basins' leaders; one within
// same_distance (and basin_yaw) of a better one is the same bottom (two climbs that met or
// stopped a step apart) and is emptied (score -1, moved to the end).
void rank_basins(std::span<PoseSearchCandidate> hypotheses, double basin_distance, double basin_yaw,
                 double same_distance);

}  // namespace v2xloc
