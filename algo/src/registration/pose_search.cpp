#include "v2xloc/algo/registration/pose_search.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {
namespace {

struct Candidate {
  double score = -1.0;
  double x = 0.0, y = 0.0, yaw = 0.0;
};

bool same_basin(const Candidate& a, const Candidate& b, const PoseSearchParams& params) {
  const double dx = a.x - b.x, dy = a.y - b.y;
  return dx * dx + dy * dy < params.distinct_distance * params.distinct_distance &&
         std::abs(det::wrap_pi(a.yaw - b.yaw)) < params.distinct_yaw;
}

// Keeps the best kPoseSearchRefine hypotheses, sorted, at most one per basin (non-maximum
// suppression): otherwise the neighbours of one strong basin fill the list, the refinement never
// sees the alternatives and the ambiguity check has no runner-up to measure.
void keep_distinct_best(Candidate (&top)[kPoseSearchRefine], const Candidate& c, const PoseSearchParams& params) {
  constexpr int kLast = static_cast<int>(kPoseSearchRefine) - 1;
  int slot = kLast;  // the entry the new candidate replaces: its basin's, else the worst
  for (int i = 0; i <= kLast; ++i) {
    if (top[i].score < 0.0 || !same_basin(top[i], c, params)) continue;
    if (top[i].score >= c.score) return;  // its basin already has a better hypothesis
    slot = i;
    break;
  }
  if (c.score <= top[slot].score) return;
  int j = slot;
  while (j > 0 && top[j - 1].score < c.score) {
    top[j] = top[j - 1];
    --j;
  }
  top[j] = c;
}

Mat4d pose_of(double x, double y, double z, double yaw) {
  Mat4d t = Mat4d::Identity();
  t.topLeftCorner<3, 3>() = rot_z(yaw);
  t(0, 3) = x;
  t(1, 3) = y;
  t(2, 3) = z;
  return t;
}

}  // namespace

bool road_height(std::span<const Vec3f> map, const Vec3d& center, double radius, double& height,
                 std::uint32_t min_points) {
  constexpr int kBins = 400;  // [-40, 40] m around the centre height
  std::uint32_t hist[kBins] = {};
  const double r2 = radius * radius;
  for (const Vec3f& p : map) {
    const double dx = p.x() - center.x(), dy = p.y() - center.y();
    if (dx * dx + dy * dy > r2) continue;
    const int b = static_cast<int>(std::floor((p.z() - center.z() + 40.0) / 0.2));
    if (b >= 0 && b < kBins) ++hist[b];
  }
  int best = -1;
  std::uint32_t count = 0;
  for (int b = 0; b < kBins; ++b) {
    if (hist[b] > count) {
      count = hist[b];
      best = b;
    }
  }
  const bool found = best >= 0 && count >= min_points;
  height = found ? center.z() - 40.0 + 0.2 * (best + 0.5) : center.z();
  return found;
}

bool road_height_near(std::span<const Vec3f> map, const Vec3d& center, double radius, double& height,
                      std::uint32_t min_points) {
  const double r2 = radius * radius;
  double sum = 0.0;
  std::uint32_t n = 0;
  for (const Vec3f& p : map) {
    const double dx = p.x() - center.x(), dy = p.y() - center.y();
    if (dx * dx + dy * dy > r2) continue;
    sum += p.z();
    ++n;
  }
  if (n == 0) {
    height = center.z();
    return false;
  }
  // Shifted by whole bins, so the bin edges stay those of a histogram centred on center.z.
  const double shift = 0.2 * std::round((sum / n - center.z()) / 0.2);
  if (road_height(map, Vec3d(center.x(), center.y(), center.z() + shift), radius, height, min_points)) return true;
  height = center.z();
  return false;
}

double ray_conflict_ratio(std::span<const Vec3f> scan_body, const IcpTarget& map, const Mat4d& pose,
                          double ground_z, const PoseSearchParams& params) {
  if (map.tree == nullptr || !(params.conflict_step > 0.0) || params.conflict_rays == 0) return -1.0;
  const Vec3d& s = params.sensor_in_body;
  const double min_range2 = params.conflict_min_range * params.conflict_min_range;
  std::uint32_t candidates = 0;
  for (const Vec3f& p : scan_body) {
    const Vec3d d = p.cast<double>() - s;
    candidates += p.z() > params.min_height && d.squaredNorm() > min_range2 ? 1u : 0u;
  }
  const std::uint32_t want = params.conflict_rays < kPoseSearchMaxConflictRays ? params.conflict_rays
                                                                                : kPoseSearchMaxConflictRays;
  if (candidates == 0) return -1.0;
  const std::uint32_t stride = candidates > want ? candidates / want : 1u;
  const Mat3d R = pose.topLeftCorner<3, 3>();
  const Vec3d origin = R * s + pose.topRightCorner<3, 1>();
  const float r2 = static_cast<float>(params.conflict_radius * params.conflict_radius);
  const double floor_z = ground_z + params.min_height;  // kerbs and the road itself are no walls
  std::uint32_t rays = 0, conflicts = 0, seen = 0;
  for (const Vec3f& p : scan_body) {
    const Vec3d d = p.cast<double>() - s;
    if (!(p.z() > params.min_height) || d.squaredNorm() <= min_range2) continue;
    if (seen++ % stride != 0 || rays >= want) continue;
    ++rays;
    const double length = d.norm();
    const Vec3d dir = R * (d / length);
    const double free = length - params.conflict_margin;
    std::uint32_t hint = KdTree<Vec3f>::kNoHint;
    for (std::uint32_t k = 0; k < kPoseSearchMaxRaySteps; ++k) {
      const double along = params.conflict_start + k * params.conflict_step;
      if (along >= free) break;
      const Vec3d q = origin + along * dir;
      if (q.z() < floor_z) continue;
      Neighbor nb{0, 0.0f};
      if (map.tree->nearest_within(q.cast<float>(), r2, hint, nb).count > 0) {
        ++conflicts;
        break;
      }
    }
  }
  return rays > 0 ? static_cast<double>(conflicts) / rays : -1.0;
}

PoseSearchResult search_pose(std::span<const Vec3f> scan_body, const IcpTarget& map,
                             const Vec3d& center, const PoseSearchParams& params,
                             std::span<std::uint32_t> neighbor_scratch) {
  PoseSearchResult out;
  out.best.status = RegistrationStatus::kNotEnoughPoints;
  if (map.tree == nullptr || map.points.empty() || scan_body.empty() || !(params.step > 0.0) ||
      params.yaw_steps == 0) {
    out.best.status = RegistrationStatus::kInvalidInput;
    return out;
  }
  // Fixed subsample of above-ground points (every k-th), in body coordinates.
  constexpr std::uint32_t kMaxScore = 512;
  Vec3f score_pts[kMaxScore];
  std::uint32_t above = 0;
  for (const Vec3f& p : scan_body) above += p.z() > params.min_height ? 1u : 0u;
  const std::uint32_t want = params.score_points < kMaxScore ? params.score_points : kMaxScore;
  if (above < 16) return out;
  const std::uint32_t stride = above > want ? above / want : 1u;
  std::uint32_t n = 0, seen = 0;
  for (const Vec3f& p : scan_body) {
    if (!(p.z() > params.min_height)) continue;
    if (seen++ % stride == 0 && n < want) score_pts[n++] = p;
  }

  // Not around the fix's altitude: a canyon fix can be far off vertically (TUNING.md).
  road_height_near(map.points, center, params.radius + params.ground_margin, out.ground_z);
  Candidate top[kPoseSearchRefine];
  const double d2max = params.score_distance * params.score_distance;
  // A hit needs the nearest map point within score_distance: a bounded search answers exactly
  // that without exploring the tree beyond it (the unbounded nearest of a point in free space
  // visits most of the tree).
  const float d2max_f = static_cast<float>(d2max);
  const int cells = static_cast<int>(std::floor(params.radius / params.step));
  for (int iy = -cells; iy <= cells; ++iy) {
    for (int ix = -cells; ix <= cells; ++ix) {
      const double ox = ix * params.step, oy = iy * params.step;
      if (ox * ox + oy * oy > params.radius * params.radius) continue;
      for (std::uint32_t k = 0; k < params.yaw_steps; ++k) {
        const double yaw = 2.0 * det::kPi * k / params.yaw_steps;
        if (params.use_yaw_prior && std::abs(det::wrap_pi(yaw - params.yaw_prior)) > params.yaw_prior_tolerance) continue;
        if (out.hypotheses >= params.max_hypotheses) break;
        ++out.hypotheses;
        const double c = det::cos(yaw), s = det::sin(yaw);
        const double x = center.x() + ox, y = center.y() + oy;
        std::uint32_t hits = 0;
        for (std::uint32_t i = 0; i < n; ++i) {
          const Vec3f& p = score_pts[i];
          const Vec3f q(static_cast<float>(c * p.x() - s * p.y() + x),
                        static_cast<float>(s * p.x() + c * p.y() + y),
                        static_cast<float>(p.z() + out.ground_z));
          Neighbor nb{0, 0.0f};
          if (map.tree->nearest_within(q, d2max_f, KdTree<Vec3f>::kNoHint, nb).count > 0 &&
              nb.squared_distance <= d2max) {
            ++hits;
          }
        }
        const double score = static_cast<double>(hits) / n;
        keep_distinct_best(top, Candidate{score, x, y, yaw}, params);
      }
    }
  }
  // Refine the best hypotheses (coarse then fine ICP). Aliased poses along a straight canyon
  // reach similar fitness at a coarse threshold but not the fine RMSE of the true pose.
  RegistrationResult refined[kPoseSearchRefine];
  double best_fitness = 0.0;
  for (std::uint32_t i = 0; i < kPoseSearchRefine; ++i) {
    const Candidate& cand = top[i];
    refined[i].status = RegistrationStatus::kDidNotConverge;
    if (cand.score < 0.0) continue;
    const RegistrationResult coarse =
        icp(scan_body, map, pose_of(cand.x, cand.y, out.ground_z, cand.yaw), params.icp, neighbor_scratch);
    if (!coarse.ok()) continue;
    refined[i] = icp(scan_body, map, coarse.transform, params.fine_icp, neighbor_scratch);
    if (refined[i].ok() && params.use_yaw_prior &&
        std::abs(det::wrap_pi(yaw_of(refined[i].transform.topLeftCorner<3, 3>()) - params.yaw_prior)) >
            params.yaw_prior_tolerance) {
      refined[i].status = RegistrationStatus::kDidNotConverge;  // slid out of the prior
    }
    if (refined[i].ok() && refined[i].fitness > best_fitness) best_fitness = refined[i].fitness;
  }
  // The winner: the highest fitness at a tight threshold (an aliased pose explains the scan at
  // 1 m but not at 0.3 m; inlier RMSE at a loose threshold does not separate them), among the
  // poses whose rays do not cross the map's surfaces (max_conflicts).
  double tight[kPoseSearchRefine];
  double conflicts[kPoseSearchRefine];
  double best_tight = -1.0;
  std::uint32_t winner = kPoseSearchRefine;
  for (std::uint32_t i = 0; i < kPoseSearchRefine; ++i) {
    const RegistrationResult& r = refined[i];
    tight[i] = -1.0;
    conflicts[i] = -1.0;
    if (!r.ok() || r.fitness < best_fitness - 0.1) continue;
    if (params.max_conflicts > 0.0) {
      conflicts[i] = ray_conflict_ratio(scan_body, map, r.transform, out.ground_z, params);
      if (conflicts[i] > params.max_conflicts) {
        ++out.conflict_rejected;
        continue;
      }
    }
    tight[i] = evaluate_registration(scan_body, map, r.transform, params.select_distance).fitness;
    if (tight[i] > best_tight) {
      best_tight = tight[i];
      winner = i;
    }
  }
  if (winner == kPoseSearchRefine) return out;
  out.best = refined[winner];
  out.best_score = top[winner].score;
  out.best_tight_fitness = best_tight;
  // Runner-up: the best candidate that is a different pose (not the same basin).
  for (std::uint32_t i = 0; i < kPoseSearchRefine; ++i) {
    if (i == winner || tight[i] < 0.0) continue;
    const Mat4d d = se3_inverse(refined[winner].transform) * refined[i].transform;
    const double dist = std::sqrt(d(0, 3) * d(0, 3) + d(1, 3) * d(1, 3));
    const double dyaw = std::abs(det::wrap_pi(yaw_of(d.topLeftCorner<3, 3>())));
    if (dist < params.distinct_distance && dyaw < params.distinct_yaw) continue;
    if (tight[i] > out.runner_up_tight_fitness) {
      out.runner_up_tight_fitness = tight[i];
      out.runner_up = refined[i];
      out.runner_up_conflicts = conflicts[i];
    }
  }
  out.best_conflicts = conflicts[winner];
  return out;
}

}  // namespace v2xloc
