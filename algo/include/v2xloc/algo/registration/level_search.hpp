// Level search: registration of two clouds from upright sensors (both z axes point up to within
// a few degrees, as LiDARs on vehicles and poles are mounted) without features. The transform is
// searched over x, y and yaw on a lattice, its z taken from the two clouds' ground heights; each
// hypothesis is scored by the fraction of the source's above-ground points that land near a
// target point (a proximity grid over the target). The best hypotheses climb to their basins'
// bottoms (basin_climb.hpp) and are ranked one per basin; register_clouds (mode kLevelSearch)
// then refines them by ICP. FPFH correspondences between a vehicle and a roadside LiDAR tens of
// metres apart match little (different viewpoints and densities); the overlap of the occupied
// space does not depend on descriptors.
// Work: hypotheses * score_points grid lookups (hypotheses <= max_hypotheses), plus
// kLevelSearchMaxKept climbs; no heap, all storage in LevelSearchWorkspace.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/registration/basin_climb.hpp"
#include "v2xloc/algo/search/proximity_grid.hpp"

namespace v2xloc {

inline constexpr std::uint32_t kLevelSearchMaxScorePoints = 512;  // [points] scored per hypothesis
inline constexpr std::uint32_t kLevelSearchMaxKept = 32;          // [hypotheses] kept for the climb
inline constexpr std::uint32_t kLevelSearchMaxYawSteps = 720;     // [headings] lattice maximum

struct LevelSearchParams {
  double radius = 80.0;            // [m] the source origin lies within this of the centre (horizontal, target frame)
  double step = 2.0;               // [m] position lattice spacing
  double yaw_span = 6.283185307179586;  // [rad] headings searched: centre yaw +- span / 2 (2 pi: all)
  std::uint32_t yaw_steps = 72;    // [headings] over yaw_span (<= kLevelSearchMaxYawSteps; 72 over 2 pi: 5 deg)
  std::uint32_t score_points = 384;  // [points] even subsample of above-ground source points (<= 512)
  double min_height = 1.0;         // [m] source points this far above the source's ground are scored (ground matches anywhere)
  double max_height = 6.0;         // [m] ... and at most this far (pole tops, trees: seen by one sensor only)
  double ground_radius = 25.0;     // [m] each cloud's ground height from its points within this of its origin (horizontal)
  float grid_cell = 0.5f;          // [m] proximity grid cell over the target
  float grid_reach = 1.0f;         // [m] a score point within this of a target point is a hit
  double grid_range = 100.0;       // [m] the grid covers target points within this of the target origin (horizontal)
  std::uint32_t kept = 16;         // [hypotheses] best distinct hypotheses kept (<= kLevelSearchMaxKept)
  double distinct_distance = 4.0;  // [m] hypotheses closer than this ...
  double distinct_yaw = 0.17;      // [rad] ... and this in yaw share a basin (one kept)
  std::uint32_t climb_rounds = 4;  // [moves] basin climb of each kept hypothesis (0: none)
  double climb_step = 1.0;         // [m]
  std::uint64_t max_hypotheses = 2000000;  // [hypotheses] hard cap on the lattice (worst-case time)
};

struct LevelSearchHypothesis {
  double score = -1.0;             // [0-1] fraction of score points near the target; < 0: empty
  Mat4d transform = Mat4d::Identity();  // p_target = transform * p_source
};

enum class LevelSearchStatus : std::uint8_t { kOk, kInvalidInput, kNotEnoughPoints, kGridTooSmall };

struct LevelSearchResult {
  LevelSearchStatus status = LevelSearchStatus::kInvalidInput;
  LevelSearchHypothesis kept[kLevelSearchMaxKept];  // best first, one per basin
  std::uint32_t kept_count = 0;
  std::uint64_t hypotheses = 0;    // scored on the lattice
  std::uint32_t score_points = 0;  // used
  double source_ground_z = 0.0, target_ground_z = 0.0;  // [m] each cloud's own frame
};

// All storage (the proximity grid dominates: config::kProximityGridWords words).
struct LevelSearchWorkspace {
  ProximityGrid grid;
  Vec3f score_points[kLevelSearchMaxScorePoints];   // source, shifted so its ground is z = 0
  Vec3f rotated[kLevelSearchMaxScorePoints];
  PoseSearchCandidate candidates[kLevelSearchMaxKept];
  ClimbScratch climb;                               // the kept hypotheses' basin climbs
};

// Searches p_target = T p_source with T = [Rz(yaw) | (x, y, z)] around center_x, center_y,
// center_yaw (the initial guess; 0, 0, 0 and the whole disc / all headings without one).
LevelSearchResult level_search(std::span<const Vec3f> source, std::span<const Vec3f> target, double center_x,
                               double center_y, double center_yaw, const LevelSearchParams& params,
                               LevelSearchWorkspace& workspace);

}  // namespace v2xloc
