// Map fusion's tuning values, one line each (unit and rule); the measurements behind the
// consistency thresholds are in algo/TUNING.md ("Map fusion").
#pragma once

#include <cstdint>

#include "v2xloc/algo/core/config.hpp"

namespace v2xloc {

struct MapFusionParams {
  double voxel_size = 0.2;  // [m] map resolution (registration voxel size)
  double max_age = 2.0;     // [s] sources older than this are evicted by expire()
  bool check_consistency = true;
  // Agents fill gaps only: an agent's points within ~agent_fill_cell of a fused infrastructure
  // point are dropped (its self-localized copy of a surface the infrastructure sees only blurs
  // it). 0 keeps every agent point.
  double agent_fill_cell = 0.5;  // [m]
  // Sources per role: invented agent ids cannot evict surveyed infrastructure, nor the reverse.
  std::uint32_t max_trusted_sources = config::kMaxMapSources / 2;
  std::uint32_t max_agent_sources = config::kMaxMapSources / 2;

  // ---- Consistency check (map_consistency.hpp): the candidate's offset against a reference,
  // estimated by a translation-only point-to-plane ICP of reference points on the candidate's
  // local planes, where the two overlap.
  double plane_cell = 1.0;               // [m] cell of the candidate's local planes (5x the voxel)
  std::uint32_t plane_min_points = 6;    // points for a plane (a 1 m cell of a 0.2 m grid holds ~25)
  double plane_max_flatness = 0.05;      // smallest / middle covariance eigenvalue of a plane
  // [m] spread (sqrt of the middle eigenvalue) a plane needs: a single far scan line in a cell is
  // a line, its "normal" any direction around it (a full 1 m patch: ~0.29 m)
  double plane_min_spread = 0.15;
  double match_distance = 1.0;           // [m] first ICP gate (captures a 0.5 m shift); halves per iteration
  double final_match_distance = 0.15;    // [m] gate the gate halves down to, and the verdict's gate
  double inlier_distance = 0.1;          // [m] residual of an inlier at the final offset
  std::uint32_t min_overlap_points = 50; // fewer matched reference points: no verdict (Sim 0 2_infra pair: 60-70)
  // Smallest eigenvalue of sum(n n^T) over the matched points, per point: a direction constrained
  // by fewer than ~this share of the normals is unobserved (ground only: x and y free).
  double min_constraint = 0.02;
  // Offset above which a cloud disagrees. Surveyed infrastructure is exact (genuine pairs: see
  // TUNING.md); agents place their clouds by their own localization (sim: 5 cm / 0.2 deg bias).
  double max_offset_infra = 0.1;  // [m]
  double max_offset_agent = 0.15; // [m]
  double min_inlier_fraction = 0.5;  // inliers / matched at the final offset, else disagree
  // Far search (shifts beyond the ICP's ~1 m reach): the reference displaced on a horizontal grid
  // (step search_step, outside +-1 step) must cover (1 + search_margin) times more of the
  // candidate's cells than at zero to give the ICP a second start.
  double search_step = 1.0;    // [m] (x config::kMapCheckSearchSteps per side)
  double search_margin = 0.2;  // fraction
};

}  // namespace v2xloc
