#include "v2xloc/algo/localization/map_consistency.hpp"

#include <cmath>

#include "v2xloc/algo/core/symmetric_eigen.hpp"

namespace v2xloc {

std::uint32_t MapConsistencyCheck::set_candidate(std::span<const Vec3f> candidate, const MapFusionParams& params) {
  params_ = params;
  return planes_.build(candidate, params.plane_cell, params.plane_min_points, params.plane_max_flatness,
                      params.plane_min_spread);
}

// Even stride over the union of the ranges (at most kMapCheckMaxExamined looked up); the points
// inside the candidate's cells are the overlap. The ICP's points: those in cells that are not
// level first, up to three quarters of the cap (walls fix the horizontal offset; ground, most of
// any street cloud, only the height), then level ones up to the cap, each an even stride.
void MapConsistencyCheck::sample_overlap(std::span<const std::span<const Vec3f>> ranges, MapCheckResult& r) {
  overlap_.clear();
  level_.clear();
  search_.clear();
  upright_ = 0;
  matched_.clear();
  std::size_t total = 0;
  for (const std::span<const Vec3f>& range : ranges) total += range.size();
  if (total == 0) return;
  const std::size_t stride = (total + config::kMapCheckMaxExamined - 1) / config::kMapCheckMaxExamined;
  std::size_t index = 0, level = 0, examined = 0;
  const std::size_t examined_total = (total + stride - 1) / stride;
  const std::size_t search_stride = (examined_total + config::kMapCheckSearchPoints - 1) / config::kMapCheckSearchPoints;
  for (const std::span<const Vec3f>& range : ranges) {
    for (std::size_t i = (stride - index % stride) % stride; i < range.size(); i += stride) {
      if (examined++ % search_stride == 0) search_.push_back(range[i]);
      const int occupancy = planes_.occupancy(range[i].cast<double>());
      if (occupancy == 0) continue;
      overlap_.push_back(range[i]);
      level_.push_back(occupancy == 1 ? 1 : 0);
      level += occupancy == 1 ? 1 : 0;
    }
    index += range.size();
  }
  r.overlap_points = static_cast<std::uint32_t>(overlap_.size());
  const std::size_t cap = config::kMapCheckMaxPoints;
  const std::size_t other = overlap_.size() - level;
  const std::size_t other_cap = cap - cap / 4;  // a quarter stays for the ground: it fixes the height
  const std::size_t other_keep = other < other_cap ? other : other_cap;
  const std::size_t level_keep = level < cap - other_keep ? level : cap - other_keep;
  take_even(0, other, other_keep);
  r.sampled_upright = static_cast<std::uint32_t>(matched_.size());
  upright_ = matched_.size();
  take_even(1, level, level_keep);
  r.sampled_points = static_cast<std::uint32_t>(matched_.size());
}

// Appends `keep` of the `count` overlap points with level_ == flag, at an even stride.
void MapConsistencyCheck::take_even(std::uint8_t flag, std::size_t count, std::size_t keep) {
  if (keep == 0) return;
  std::size_t seen = 0, taken = 0;
  for (std::size_t i = 0; i < overlap_.size() && taken < keep; ++i) {
    if (level_[i] != flag) continue;
    if ((seen++ * keep) % count < keep) {  // Bresenham-style: keep points spread evenly
      matched_.push_back(overlap_[i]);
      ++taken;
    }
  }
}

MapConsistencyCheck::Normals MapConsistencyCheck::accumulate(const Vec3d& offset, double gate,
                                                             std::uint32_t* matched_upright) {
  Normals n;
  for (std::size_t i = 0; i < matched_.size(); ++i) {
    const PlaneMatch m = planes_.nearest_plane(matched_[i].cast<double>() + offset);
    if (!m.found || std::abs(m.residual) > gate) continue;
    if (matched_upright != nullptr && i < upright_) ++*matched_upright;
    // Tukey's biweight: surfaces that differ between the two clouds (a car scanned at another
    // instant by each unit) fade out instead of pulling the offset.
    const double u = m.residual / gate;
    const double w = (1.0 - u * u) * (1.0 - u * u);
    n.a += w * (m.normal * m.normal.transpose());
    n.b += w * m.residual * m.normal;
    n.weight += w;
    ++n.matched;
    if (std::abs(m.residual) <= params_.inlier_distance) ++n.inliers;
  }
  return n;
}

// Minimises sum (n . (q + offset - c))^2 over the offset: the step is -A^-1 b restricted to the
// eigen-directions that at least min_constraint of the matched normals constrain.
double MapConsistencyCheck::solve_step(const Normals& n, Vec3d& step) const {
  step.setZero();
  if (n.matched == 0) return 0.0;
  Vec3d lambda;
  Mat3d v;
  symmetric_eigen3(n.a, lambda, v);
  const double floor = params_.min_constraint * n.weight;
  for (int k = 0; k < 3; ++k) {
    if (lambda(k) >= floor && lambda(k) > 0.0) step -= v.col(k) * (v.col(k).dot(n.b) / lambda(k));
  }
  return n.weight > 0.0 ? lambda(0) / n.weight : 0.0;
}

MapCheckVerdict MapConsistencyCheck::verdict(const MapCheckResult& r, bool observed, double max_offset) const {
  if (r.matched_points < params_.min_overlap_points) return MapCheckVerdict::kUncheckable;
  // An offset in the observed directions is evidence even when another direction is free.
  if (r.offset.norm() > max_offset) return MapCheckVerdict::kDisagree;
  if (!observed) return MapCheckVerdict::kUncheckable;
  if (r.inlier_fraction < params_.min_inlier_fraction) return MapCheckVerdict::kDisagree;
  return MapCheckVerdict::kAgree;
}

// Translation ICP from `start`, the gate halving from match_distance to final_match_distance.
Vec3d MapConsistencyCheck::refine(const Vec3d& start, std::uint32_t& iterations) {
  Vec3d offset = start;
  double gate = params_.match_distance;
  for (std::uint32_t it = 0; it < config::kMapCheckMaxIterations; ++it) {
    const Normals n = accumulate(offset, gate);
    iterations += 1;
    if (n.matched < params_.min_overlap_points) break;
    Vec3d step;
    solve_step(n, step);
    offset += step;
    const bool at_final_gate = gate <= params_.final_match_distance;
    gate = 0.5 * gate > params_.final_match_distance ? 0.5 * gate : params_.final_match_distance;
    if (at_final_gate && step.norm() < 1e-4) break;
  }
  return offset;
}

// Reference points in the candidate's occupied cells when displaced by `offset`.
std::uint32_t MapConsistencyCheck::occupied_hits(const Vec3d& offset) const {
  std::uint32_t hits = 0;
  for (const Vec3f& q : search_) hits += planes_.occupied(q.cast<double>() + offset) ? 1u : 0u;
  return hits;
}

// Shifts beyond the ICP's reach (a street's walls slide onto themselves, the others leave the
// gate, and the ICP agrees at zero): the reference, displaced on a horizontal grid of search_step
// outside the ICP's reach, covers the candidate's cells far better somewhere -> start there.
bool MapConsistencyCheck::far_search(Vec3d& start) const {
  const std::uint32_t at_zero = occupied_hits(Vec3d::Zero());
  const auto n = static_cast<std::int32_t>(config::kMapCheckSearchSteps);
  std::uint32_t best = 0;
  for (std::int32_t i = -n; i <= n; ++i) {
    for (std::int32_t j = -n; j <= n; ++j) {
      if (i >= -1 && i <= 1 && j >= -1 && j <= 1) continue;  // the ICP's own neighbourhood
      const Vec3d o(i * params_.search_step, j * params_.search_step, 0.0);
      const std::uint32_t hits = occupied_hits(o);
      if (hits > best) {
        best = hits;
        start = o;
      }
    }
  }
  return best > at_zero + at_zero * params_.search_margin;
}

MapCheckResult MapConsistencyCheck::check(std::span<const std::span<const Vec3f>> ranges, double max_offset) {
  MapCheckResult r;
  sample_overlap(ranges, r);
  if (matched_.size() < params_.min_overlap_points) return r;  // uncheckable, no ICP
  Vec3d offset = refine(Vec3d::Zero(), r.iterations);
  Vec3d start;
  if (far_search(start)) {
    const Vec3d far = refine(start, r.iterations);
    if (accumulate(far, params_.final_match_distance).matched > accumulate(offset, params_.final_match_distance).matched) {
      offset = far;
      r.far = true;
    }
  }
  const Normals last = accumulate(offset, params_.final_match_distance, &r.matched_upright);
  Vec3d unused;
  r.weakest_constraint = solve_step(last, unused);
  r.matched_points = last.matched;
  r.inlier_fraction = last.matched > 0 ? static_cast<double>(last.inliers) / last.matched : 0.0;
  r.offset = offset;
  r.verdict = verdict(r, r.weakest_constraint >= params_.min_constraint, max_offset);
  return r;
}

}  // namespace v2xloc
