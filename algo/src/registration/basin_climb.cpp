#include "v2xloc/algo/registration/basin_climb.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/even_thinning.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/search/proximity_grid.hpp"

namespace v2xloc {

namespace {

// The even subsample of above-ground points at a fractional stride: the a-th above-ground point
// is taken when floor(a * take / above) steps up (all of them when above <= want). An integer
// stride would take the first `want` points, one sector of the sweep, when want < above < 2 want.
std::uint32_t rotate_subsample(std::span<const Vec3f> scan_body, double yaw, const BasinClimbParams& params,
                               ClimbScratch& scratch) {
  const std::uint32_t want = params.points < kMaxClimbPoints ? params.points : kMaxClimbPoints;
  std::uint64_t above = 0;
  for (const Vec3f& p : scan_body) above += p.z() > params.min_height ? 1u : 0u;
  if (above == 0 || want == 0) return 0;
  const std::uint64_t take = want < above ? want : above;
  const double c = det::cos(yaw), s = det::sin(yaw);
  std::uint32_t n = 0;
  std::uint64_t a = 0;
  for (const Vec3f& p : scan_body) {
    if (!(p.z() > params.min_height)) continue;
    const std::uint64_t i = a++;
    if (!kept_evenly(i, above, take)) continue;
    scratch.points[n++] = ClimbPoint{c * p.x() - s * p.y(), s * p.x() + c * p.y(), static_cast<float>(p.z() + params.ground_z)};
  }
  return n;
}

// Where a climb looks points up, resolved once: the proximity grid when it is usable, else the
// k-d tree within score_distance; neither: nothing to score.
struct Lookup {
  const ProximityGrid* grid = nullptr;
  const KdTree<Vec3f>* tree = nullptr;
  float d2max = 0.0f;
  bool usable() const { return grid != nullptr || tree != nullptr; }
};
Lookup lookup_of(const ClimbTarget& target, const BasinClimbParams& params) {
  const bool grid_ok = target.grid != nullptr && target.grid->ready() && target.grid->valid();
  return Lookup{grid_ok ? target.grid : nullptr, grid_ok ? nullptr : target.tree,
                squared_radius_not_above(params.score_distance)};
}

// Score of the rotated points placed at (x, y); -1 without points or map.
double score_at(const Lookup& lookup, const ClimbScratch& scratch, std::uint32_t n, double x, double y, ClimbWork* work) {
  if (n == 0 || !lookup.usable()) return -1.0;
  std::uint32_t hits = 0;
  std::uint64_t visits = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const ClimbPoint& p = scratch.points[i];
    const Vec3f q(static_cast<float>(p.x + x), static_cast<float>(p.y + y), p.z);
    hits += (lookup.grid != nullptr ? lookup.grid->near(q) : lookup.tree->any_within(q, lookup.d2max, &visits)) ? 1u : 0u;
  }
  if (work != nullptr) {
    work->lookups += n;
    work->node_visits += visits;
  }
  return static_cast<double>(hits) / n;
}

// Where a parabola through (-1, before), (0, at), (1, after) peaks, in steps, within +-0.5; 0
// when the three do not bend down (flat or not a top).
double peak_offset(double before, double at, double after) {
  const double curvature = before - 2.0 * at + after;
  if (!(curvature < 0.0)) return 0.0;
  const double offset = 0.5 * (before - after) / curvature;
  return offset > 0.5 ? 0.5 : (offset < -0.5 ? -0.5 : offset);
}

}  // namespace

double climb_score(const ClimbTarget& target, double x, double y, double yaw, const BasinClimbParams& params,
                   ClimbScratch& scratch, ClimbWork* work) {
  const std::uint32_t n = rotate_subsample(target.scan_body, yaw, params, scratch);
  return score_at(lookup_of(target, params), scratch, n, x, y, work);
}

void climb_pose(const ClimbTarget& target, PoseSearchCandidate& h, const BasinClimbParams& params,
                ClimbScratch& scratch, ClimbWork* work) {
  const Lookup lookup = lookup_of(target, params);
  const std::uint32_t n = rotate_subsample(target.scan_body, h.yaw, params, scratch);
  h.score = score_at(lookup, scratch, n, h.x, h.y, work);
  if (!(h.score >= 0.0)) return;
  const std::uint32_t rounds = params.rounds < kMaxClimbRounds ? params.rounds : kMaxClimbRounds;
  for (std::uint32_t round = 0; round < rounds; ++round) {
    PoseSearchCandidate best = h;
    double around[3][3] = {};  // scores of h's neighbours, [dy + 1][dx + 1]
    around[1][1] = h.score;
    // The 8 neighbours in a fixed order; a tie keeps the earlier one (same input, same climb).
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0) continue;
        const double nx = h.x + dx * params.step, ny = h.y + dy * params.step;
        const double score = score_at(lookup, scratch, n, nx, ny, work);
        around[dy + 1][dx + 1] = score;
        if (score > best.score) best = PoseSearchCandidate{score, nx, ny, h.yaw};
      }
    }
    if (!(best.score > h.score)) {
      // A top: the score (points within a few grid cells of the map) is a broad, flat peak, and
      // its bottom lies between the steps. A parabola through each axis' three scores puts it
      // there (at most half a step away; h.score stays the score measured at h).
      h.x += params.step * peak_offset(around[1][0], around[1][1], around[1][2]);
      h.y += params.step * peak_offset(around[0][1], around[1][1], around[2][1]);
      return;
    }
    h = best;
  }
}

void rank_basins(std::span<PoseSearchCandidate> hypotheses, double basin_distance, double basin_yaw,
                 double same_distance) {
  const std::size_t n = hypotheses.size();
  // Best first; stable (insertion sort: n is a few tens), empty slots last.
  for (std::size_t i = 1; i < n; ++i) {
    const PoseSearchCandidate h = hypotheses[i];
    std::size_t j = i;
    while (j > 0 && hypotheses[j - 1].score < h.score) {
      hypotheses[j] = hypotheses[j - 1];
      --j;
    }
    hypotheses[j] = h;
  }
  const double r2 = basin_distance * basin_distance;
  const double same2 = same_distance * same_distance;
  // Followers (within a better leader's basin) move behind all leaders, order kept; duplicates go.
  std::size_t leaders = 0;
  for (std::size_t i = 0; i < n; ++i) {
    PoseSearchCandidate h = hypotheses[i];
    if (!(h.score >= 0.0)) continue;
    bool follower = false, duplicate = false;
    for (std::size_t k = 0; k < i; ++k) {
      const PoseSearchCandidate& b = hypotheses[k];
      if (!(b.score >= 0.0)) continue;
      const double dx = h.x - b.x, dy = h.y - b.y, d2 = dx * dx + dy * dy;
      const bool same_yaw = std::abs(det::wrap_pi(h.yaw - b.yaw)) < basin_yaw;
      duplicate = duplicate || (same_yaw && d2 <= same2);
      follower = follower || (k < leaders && same_yaw && d2 < r2);  // only leaders define basins
    }
    if (duplicate) {
      hypotheses[i].score = -1.0;
      continue;
    }
    if (follower) continue;
    // A leader: move it up to just behind the previous leaders (shifting followers back by one).
    for (std::size_t j = i; j > leaders; --j) hypotheses[j] = hypotheses[j - 1];
    hypotheses[leaders++] = h;
  }
  // Emptied duplicates to the end, order of the rest kept.
  std::size_t out = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (hypotheses[i].score >= 0.0) hypotheses[out++] = hypotheses[i];
  }
  for (; out < n; ++out) hypotheses[out] = PoseSearchCandidate{};
}

}  // namespace v2xloc
