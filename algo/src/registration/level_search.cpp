#include "v2xloc/algo/registration/level_search.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/even_thinning.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {
namespace {

constexpr double kTwoPi = 2.0 * det::kPi;

bool params_valid(const LevelSearchParams& p) {
  return std::isfinite(p.radius) && p.radius >= 0.0 && p.step > 0.0 && p.yaw_steps > 0 &&
         p.yaw_steps <= kLevelSearchMaxYawSteps && p.yaw_span >= 0.0 && p.score_points > 0 &&
         p.max_height > p.min_height && p.ground_radius > 0.0 && p.grid_cell > 0.0f && p.grid_reach >= 0.0f &&
         p.grid_range > 0.0 && p.kept > 0 && p.distinct_distance >= 0.0 && p.climb_step > 0.0;
}

// Even subsample (fractional stride) of the source points between min_height and max_height
// above its ground, shifted so that ground is z = 0.
std::uint32_t pick_score_points(std::span<const Vec3f> source, double ground_z, const LevelSearchParams& params,
                                Vec3f* out) {
  const std::uint32_t want =
      params.score_points < kLevelSearchMaxScorePoints ? params.score_points : kLevelSearchMaxScorePoints;
  const auto in_band = [&](const Vec3f& p) {
    const double h = p.z() - ground_z;
    return h >= params.min_height && h <= params.max_height;
  };
  std::uint64_t band = 0;
  for (const Vec3f& p : source) band += in_band(p) ? 1u : 0u;
  if (band == 0) return 0;
  const std::uint64_t take = want < band ? want : band;
  std::uint32_t n = 0;
  std::uint64_t a = 0;
  for (const Vec3f& p : source) {
    if (!in_band(p)) continue;
    const std::uint64_t i = a++;
    if (!kept_evenly(i, band, take)) continue;
    out[n++] = Vec3f(p.x(), p.y(), static_cast<float>(p.z() - ground_z));
  }
  return n;
}

double yaw_at(std::uint32_t i, double center_yaw, const LevelSearchParams& p) {
  if (p.yaw_span >= kTwoPi) return det::wrap_pi(center_yaw + kTwoPi * i / p.yaw_steps);
  if (p.yaw_steps == 1) return center_yaw;
  return det::wrap_pi(center_yaw - 0.5 * p.yaw_span + p.yaw_span * i / (p.yaw_steps - 1));
}

bool same_basin(const PoseSearchCandidate& a, const PoseSearchCandidate& b, const LevelSearchParams& p) {
  const double dx = a.x - b.x, dy = a.y - b.y;
  return dx * dx + dy * dy < p.distinct_distance * p.distinct_distance &&
         std::abs(det::wrap_pi(a.yaw - b.yaw)) < p.distinct_yaw;
}

// Keeps the best hypothesis of each basin among the `cap` best: h enters unless a better one
// shares its basin, and evicts the worse ones that share it. Ties keep the earlier (lattice order).
void keep(PoseSearchCandidate* kept, std::uint32_t& count, std::uint32_t cap, const PoseSearchCandidate& h,
          const LevelSearchParams& p) {
  if (count == cap && !(h.score > kept[count - 1].score)) return;
  for (std::uint32_t i = 0; i < count; ++i) {
    if (kept[i].score >= h.score && same_basin(kept[i], h, p)) return;
  }
  std::uint32_t out = 0;
  for (std::uint32_t i = 0; i < count; ++i) {
    if (!same_basin(kept[i], h, p)) kept[out++] = kept[i];
  }
  count = out;
  if (count == cap) --count;  // drop the worst
  std::uint32_t j = count++;
  while (j > 0 && kept[j - 1].score < h.score) {
    kept[j] = kept[j - 1];
    --j;
  }
  kept[j] = h;
}

Mat4d transform_of(const PoseSearchCandidate& h, double z) {
  Mat4d t = Mat4d::Identity();
  const double c = det::cos(h.yaw), s = det::sin(h.yaw);
  t(0, 0) = c;
  t(0, 1) = -s;
  t(1, 0) = s;
  t(1, 1) = c;
  t(0, 3) = h.x;
  t(1, 3) = h.y;
  t(2, 3) = z;
  return t;
}

}  // namespace

LevelSearchResult level_search(std::span<const Vec3f> source, std::span<const Vec3f> target, double center_x,
                               double center_y, double center_yaw, const LevelSearchParams& params,
                               LevelSearchWorkspace& ws) {
  LevelSearchResult out;
  if (!params_valid(params) || !std::isfinite(center_x) || !std::isfinite(center_y) || !std::isfinite(center_yaw)) {
    return out;
  }
  const Vec3d origin = Vec3d::Zero();
  const bool source_ground = road_height_near(source, origin, params.ground_radius, out.source_ground_z, 16);
  const bool target_ground = road_height_near(target, origin, params.ground_radius, out.target_ground_z, 16);
  const std::uint32_t n = pick_score_points(source, out.source_ground_z, params, ws.score_points);
  out.score_points = n;
  if (!source_ground || !target_ground || n < 16) {
    out.status = LevelSearchStatus::kNotEnoughPoints;
    return out;
  }
  const double gz = out.target_ground_z;
  const double half_z = 0.5 * (params.max_height - params.min_height) + params.grid_reach + 1.0;
  ws.grid.build(target, Vec3d(0.0, 0.0, gz + 0.5 * (params.min_height + params.max_height)),
                Vec3d(params.grid_range, params.grid_range, half_z), ProximityGridParams{params.grid_cell, params.grid_reach});
  if (!ws.grid.valid()) {
    out.status = LevelSearchStatus::kGridTooSmall;
    return out;
  }

  const std::uint32_t cap = params.kept < kLevelSearchMaxKept ? params.kept : kLevelSearchMaxKept;
  std::uint32_t count = 0;
  const int cells = static_cast<int>(std::floor(params.radius / params.step));
  const double r2 = (params.radius / params.step) * (params.radius / params.step);
  for (std::uint32_t k = 0; k < params.yaw_steps; ++k) {
    const double yaw = yaw_at(k, center_yaw, params);
    const double c = det::cos(yaw), s = det::sin(yaw);
    for (std::uint32_t i = 0; i < n; ++i) {
      const Vec3f& p = ws.score_points[i];
      ws.rotated[i] = Vec3f(static_cast<float>(c * p.x() - s * p.y()), static_cast<float>(s * p.x() + c * p.y()),
                            static_cast<float>(p.z() + gz));
    }
    for (int iy = -cells; iy <= cells; ++iy) {
      for (int ix = -cells; ix <= cells; ++ix) {
        if (static_cast<double>(ix * ix + iy * iy) > r2 || out.hypotheses >= params.max_hypotheses) continue;
        ++out.hypotheses;
        const float x = static_cast<float>(center_x + ix * params.step);
        const float y = static_cast<float>(center_y + iy * params.step);
        std::uint32_t hits = 0;
        for (std::uint32_t i = 0; i < n; ++i) {
          const Vec3f& q = ws.rotated[i];
          hits += ws.grid.near(Vec3f(q.x() + x, q.y() + y, q.z())) ? 1u : 0u;
        }
        const PoseSearchCandidate h{static_cast<double>(hits) / n, static_cast<double>(x), static_cast<double>(y), yaw};
        keep(ws.candidates, count, cap, h, params);
      }
    }
  }

  // Each kept hypothesis to its basin's bottom, then one per basin, best first.
  BasinClimbParams bp;
  bp.points = n;
  bp.rounds = params.climb_rounds;
  bp.step = params.climb_step;
  bp.min_height = 0.0;  // the score points are above ground already
  bp.ground_z = gz;
  const ClimbTarget climb_target{std::span<const Vec3f>(ws.score_points, n), &ws.grid, nullptr};
  for (std::uint32_t i = 0; i < count && params.climb_rounds > 0; ++i) climb_pose(climb_target, ws.candidates[i], bp, ws.climb);
  rank_basins(std::span<PoseSearchCandidate>(ws.candidates, count), params.distinct_distance, params.distinct_yaw,
              0.5 * params.climb_step);
  const double z = out.target_ground_z - out.source_ground_z;
  for (std::uint32_t i = 0; i < count; ++i) {
    if (!(ws.candidates[i].score >= 0.0)) break;
    out.kept[out.kept_count++] = LevelSearchHypothesis{ws.candidates[i].score, transform_of(ws.candidates[i], z)};
  }
  out.status = LevelSearchStatus::kOk;
  return out;
}

}  // namespace v2xloc
