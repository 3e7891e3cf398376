#include "v2xloc/algo/registration/pose_search.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/search/proximity_grid.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {
namespace {

using Candidate = PoseSearchCandidate;
// Work accounting in kPoseSearchWorkUnit (~110 instructions), callgrind x86-64 -O2: a score
// point's proximity-grid lookup with its transform costs ~30-70, a proximity-grid build unit ~50,
// a map point of the road-height histograms ~25.
constexpr std::uint32_t kGridLookupsPerUnit = 2;
constexpr std::uint64_t kGridBuildPerUnit = 2;
constexpr std::uint64_t kRoadHeightPointsPerUnit = 4;
constexpr std::uint64_t kHypothesisUnits = 2;  // a hypothesis's own set-up and ranking

// The lattice form of scoring (proximity_grid.hpp cell_xy / near_cell): hypotheses a whole number
// of grid cells apart put a score point into its cell at the search's centre shifted by whole
// cells, so each score point's cell is taken once per heading (PoseSearchScratch::lattice) and
// each hypothesis only adds its offset (~33 instructions a lookup with its loop instead of ~65).
// A cell's edge counts with the real-valued position: a point within rounding of a cell edge may
// fall on the other side than the float query of near() puts it.
constexpr std::uint32_t kLatticeLookupsPerUnit = 3;  // ~33 instructions a lookup with its loop (callgrind)

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
  // Most hypotheses score below a full list's worst: whatever their basin, they change nothing.
  if (top[kLast].score >= c.score) return;
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
  constexpr int kBins = 400;  // 2 * kRoadHeightHalfWindow / kRoadHeightBin: [-40, 40] m around center.z
  std::uint32_t hist[kBins] = {};
  const double r2 = radius * radius;
  for (const Vec3f& p : map) {
    const double dx = p.x() - center.x(), dy = p.y() - center.y();
    if (dx * dx + dy * dy > r2) continue;
    const int b =
        static_cast<int>(std::floor((p.z() - center.z() + kRoadHeightHalfWindow) / kRoadHeightBin));
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
  height = found ? center.z() - kRoadHeightHalfWindow + kRoadHeightBin * (best + 0.5) : center.z();
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
  const double shift = kRoadHeightBin * std::round((sum / n - center.z()) / kRoadHeightBin);
  if (road_height(map, Vec3d(center.x(), center.y(), center.z() + shift), radius, height, min_points)) return true;
  height = center.z();
  return false;
}

double ray_conflict_ratio(std::span<const Vec3f> scan_body, const IcpTarget& map, const Mat4d& pose,
                          double ground_z, const PoseSearchParams& params, std::uint64_t* work,
                          const ProximityGrid* free_space) {
  // A proximity grid over the same map with at least the conflict radius' reach proves most
  // samples (free space) empty in O(1); the k-d tree answers the rest. The same verdicts.
  if (free_space != nullptr && !(free_space->ready() && free_space->valid() && free_space->reach() >= params.conflict_radius)) {
    free_space = nullptr;
  }
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
      const Vec3f qf = q.cast<float>();
      if (free_space != nullptr && free_space->none_within_reach(qf)) {
        if (work != nullptr) *work += 1;
        continue;
      }
      Neighbor nb{0, 0.0f};
      const KdQueryResult qr = map.tree->nearest_within(qf, r2, hint, nb);
      if (work != nullptr) *work += 1 + qr.node_visits;
      if (qr.count > 0) {
        ++conflicts;
        break;
      }
    }
  }
  return rays > 0 ? static_cast<double>(conflicts) / rays : -1.0;
}

int clearly_fewer_conflicts(double conflicts_a, double conflicts_b, double ratio, double margin) {
  if (!(conflicts_a >= 0.0 && conflicts_b >= 0.0)) return -1;
  const bool a_lower = conflicts_a < conflicts_b;
  const double lo = a_lower ? conflicts_a : conflicts_b, hi = a_lower ? conflicts_b : conflicts_a;
  if (!(hi >= ratio * lo && hi - lo >= margin)) return -1;
  return a_lower ? 0 : 1;
}

bool replaces_best_so_far(const RatedPose& candidate, const RatedPose& best, double ambiguity, double conflict_ratio,
                          double conflict_margin) {
  const bool higher = candidate.tight > best.tight;
  const double low = higher ? best.tight : candidate.tight;
  const double high = higher ? candidate.tight : best.tight;
  if (ambiguity > 0.0 && low >= ambiguity * high) {
    const int fewer = clearly_fewer_conflicts(candidate.conflicts, best.conflicts, conflict_ratio, conflict_margin);
    if (fewer >= 0) return fewer == 0;
  }
  return higher;
}

const PoseSearchResult& PoseSearch::run(std::span<const Vec3f> scan_body, const IcpTarget& map, const Vec3d& center,
                                        const PoseSearchParams& params, PoseSearchScratch& scratch) {
  start(scan_body, map, center, params);
  while (!step(map, scratch, ~std::uint64_t{0})) {
  }
  return result_;
}

// Resets the job and copies the scan; false (result kInvalidInput) when nothing can be searched.
bool PoseSearch::copy_scan(std::span<const Vec3f> scan_body, const IcpTarget& map) {
  result_ = PoseSearchResult{};
  result_.best.status = RegistrationStatus::kNotEnoughPoints;
  work_ = 0;
  step_from_ = 0;
  phase_ = Phase::kDone;
  lattice_filled_ = false;
  from_given_ = false;
  for (std::int8_t& r : rated_) r = -1;
  grid_source_ = {};  // a grid serves the ray checks of the job that built it only
  if (map.tree == nullptr || map.points.empty() || scan_body.empty() || !(params_.step > 0.0) ||
      params_.yaw_steps == 0) {
    result_.best.status = RegistrationStatus::kInvalidInput;
    return false;
  }
  const std::size_t n = scan_body.size() < config::kMaxSearchPoints ? scan_body.size() : config::kMaxSearchPoints;
  result_.scan_points_dropped = static_cast<std::uint32_t>(scan_body.size() - n);  // callers pass <= kMaxSearchPoints (documented)
  // Every stride-th point first (the ICP's subsample, in scan order), then the others.
  const std::size_t want = params_.refine_points > 0 && params_.refine_points < n ? params_.refine_points : n;
  const std::size_t stride = want > 0 ? (n + want - 1) / want : 1;
  scan_count_ = 0;
  for (std::size_t i = 0; i < n; i += stride) scan_[scan_count_++] = scan_body[i];
  refine_count_ = scan_count_;
  for (std::size_t i = 0; i < n; ++i) {
    if (i % stride != 0) scan_[scan_count_++] = scan_body[i];
  }
  for (Candidate& c : top_) c = Candidate{};
  candidate_ = 0;
  refining_fine_ = false;
  run_started_ = false;
  best_fitness_ = 0.0;
  winner_ = kPoseSearchRefine;
  provisional_ = kPoseSearchRefine;
  leader_coarse_ok_ = false;
  return true;
}

void PoseSearch::start(std::span<const Vec3f> scan_body, const IcpTarget& map, const Vec3d& center,
                       const PoseSearchParams& params) {
  params_ = params;
  center_ = center;
  if (!copy_scan(scan_body, map)) return;
  // Fixed subsample of above-ground points (every k-th), in body coordinates, in scan order.
  const std::span<const Vec3f> body = scan_body.first(scan_count_);
  std::uint32_t above = 0;
  for (const Vec3f& p : body) above += p.z() > params.min_height ? 1u : 0u;
  const std::uint32_t want = params.score_points < kMaxScorePoints ? params.score_points : kMaxScorePoints;
  if (above < 16) return;
  const std::uint32_t stride = above > want ? above / want : 1u;
  score_count_ = 0;
  std::uint32_t seen = 0;
  for (const Vec3f& p : body) {
    if (!(p.z() > params.min_height)) continue;
    if (seen++ % stride == 0 && score_count_ < want) score_pts_[score_count_++] = p;
  }
  // Not around the fix's altitude: a canyon fix can be far off vertically (TUNING.md).
  road_height_near(map.points, center, params.radius + params.ground_margin, result_.ground_z);
  work_ += 2 * map.points.size() / kRoadHeightPointsPerUnit;  // the mean height, then the histogram
  if (grid_ != nullptr) build_grid(map);
  for (std::uint32_t i = 0; i < params.yaw_steps && i < kMaxYawTable; ++i) {
    const double yaw = 2.0 * det::kPi * i / params.yaw_steps;
    yaw_cos_[i] = det::cos(yaw);
    yaw_sin_[i] = det::sin(yaw);
  }
  cells_ = static_cast<int>(std::floor(params.radius / params.step));
  iy_ = -cells_;
  ix_ = -cells_;
  yaw_index_ = 0;
  phase_ = Phase::kScore;
}

// The proximity grid over the box every hypothesis's score points can reach: the search disc
// widened by the points' horizontal range, their height span above the road, and the reach.
// Built whole here: at most kProximityGridWords * 26 + map points work units (proximity_grid.hpp).
void PoseSearch::build_grid(const IcpTarget& map) {
  double range = 0.0, z_lo = 1e300, z_hi = -1e300;
  for (std::uint32_t i = 0; i < score_count_; ++i) {
    const Vec3f& p = score_pts_[i];
    const double r = std::sqrt(static_cast<double>(p.x()) * p.x() + static_cast<double>(p.y()) * p.y());
    range = r > range ? r : range;
    z_lo = p.z() < z_lo ? p.z() : z_lo;
    z_hi = p.z() > z_hi ? p.z() : z_hi;
  }
  const double margin = params_.score_distance;
  const Vec3d center(center_.x(), center_.y(), result_.ground_z + 0.5 * (z_lo + z_hi));
  const Vec3d half(params_.radius + range + margin, params_.radius + range + margin, 0.5 * (z_hi - z_lo) + margin);
  ProximityGridParams gp;
  gp.cell = params_.grid_cell;
  gp.reach = params_.grid_reach;
  grid_->build(map.points, center, half, gp);
  grid_source_ = map.points;
  work_ += grid_->total_work() / kGridBuildPerUnit;
}

void PoseSearch::start_from_poses(std::span<const Vec3f> scan_body, const IcpTarget& map,
                                  std::span<const Mat4d> poses, double ground_z, const PoseSearchParams& params) {
  params_ = params;
  if (!copy_scan(scan_body, map) || poses.empty()) return;
  const std::size_t n = poses.size() < kPoseSearchRefine ? poses.size() : kPoseSearchRefine;
  params_.refine_candidates = static_cast<std::uint32_t>(n);
  for (std::size_t i = 0; i < n; ++i) {
    given_[i] = poses[i];
    const Mat4d& p = poses[i];
    top_[i] = Candidate{1.0, p(0, 3), p(1, 3), yaw_of(p.topLeftCorner<3, 3>())};
  }
  center_ = poses[0].topRightCorner<3, 1>();
  result_.ground_z = ground_z;
  from_given_ = true;
  phase_ = Phase::kRefine;
}

bool PoseSearch::step(const IcpTarget& map, PoseSearchScratch& scratch, std::uint64_t budget, bool score_whole) {
  // From the previous step's end (or the job's start, so that start()'s own work counts here).
  const std::uint64_t stop = budget > ~std::uint64_t{0} - step_from_ ? ~std::uint64_t{0} : step_from_ + budget;
  if (phase_ != Phase::kDone && (map.tree == nullptr || map.points.empty())) {
    result_.best.status = RegistrationStatus::kInvalidInput;  // the map went away mid-search
    phase_ = Phase::kDone;
  }
  if (score_whole && phase_ == Phase::kScore) score_hypotheses(map, ~std::uint64_t{0}, scratch);
  while (score_whole && phase_ == Phase::kClimb) climb_candidate(map, scratch.climb);
  // At power-up the output until a refined pose exists: the best hypothesis' coarse ICP, in this
  // slice up to power_up_coarse_work units whatever the budget; the rest in the budget's slices.
  const std::uint64_t coarse_stop = work_ + params_.power_up_coarse_work;
  while (score_whole && params_.provisional_scored && phase_ == Phase::kRefine && candidate_ == 0 && !refining_fine_ &&
         work_ < coarse_stop) {
    refine_candidate(map, coarse_stop);
  }
  // Selecting among candidates their refinement already judged costs nothing: a slice spent on
  // the last refinement still finishes the search instead of leaving it for the next period.
  while (phase_ != Phase::kDone && (work_ < stop || next_step_is_free())) {
    switch (phase_) {
      case Phase::kScore: score_hypotheses(map, stop, scratch); break;
      case Phase::kClimb: climb_candidate(map, scratch.climb); break;
      case Phase::kRefine: refine_candidate(map, stop); break;
      case Phase::kSelect: select_candidate(map); break;
      case Phase::kDone: break;
    }
  }
  step_from_ = work_;
  return phase_ == Phase::kDone;
}

// Hypotheses in grid order (rows, columns, yaws), each costing score_count_ bounded queries.
void PoseSearch::score_hypotheses(const IcpTarget& map, std::uint64_t stop, PoseSearchScratch& scratch) {
  // A hit needs a map point within score_distance: any_within answers exactly that and stops at
  // the first one (the unbounded nearest of a point in free space visits most of the tree).
  const float d2max_f = squared_radius_not_above(params_.score_distance);
  const double r2 = params_.radius * params_.radius;
  // The proximity bitmap built at start(): same question, looser answer (a hit may be up to a
  // few cells farther), ~30x cheaper.
  const ProximityGrid* grid = grid_ != nullptr && grid_->ready() && grid_->valid() ? grid_ : nullptr;
  const std::int64_t lattice = grid != nullptr ? lattice_step(*grid, scratch) : 0;
  // Every hypothesis puts a score point at the same height: its grid plane is looked up once.
  std::int64_t plane[kMaxScorePoints];
  for (std::uint32_t i = 0; i < score_count_ && lattice > 0; ++i) {
    plane[i] = grid->plane_offset(static_cast<float>(score_pts_[i].z() + result_.ground_z));
  }
  for (; iy_ <= cells_; ++iy_, ix_ = -cells_) {
    for (; ix_ <= cells_; ++ix_, yaw_index_ = 0) {
      const double ox = ix_ * params_.step, oy = iy_ * params_.step;
      if (ox * ox + oy * oy > r2) continue;
      for (; yaw_index_ < params_.yaw_steps; ++yaw_index_) {
        if (work_ >= stop) return;
        const double yaw = 2.0 * det::kPi * yaw_index_ / params_.yaw_steps;
        if (params_.use_yaw_prior && std::abs(det::wrap_pi(yaw - params_.yaw_prior)) > params_.yaw_prior_tolerance) continue;
        if (result_.hypotheses >= params_.max_hypotheses) break;
        ++result_.hypotheses;
        const bool tabled = yaw_index_ < kMaxYawTable;
        const double c = tabled ? yaw_cos_[yaw_index_] : det::cos(yaw);
        const double s = tabled ? yaw_sin_[yaw_index_] : det::sin(yaw);
        const double x = center_.x() + ox, y = center_.y() + oy;
        // Exact pruning: a hypothesis that cannot beat the full list's worst changes nothing
        // (keep_distinct_best), so its scoring stops once even all remaining points could not.
        const std::int64_t to_beat = worst_kept_hits();
        std::uint32_t hits = 0, scored = 0;
        if (lattice > 0) {
          const PoseSearchLatticeCell* cells = &scratch.lattice[static_cast<std::size_t>(yaw_index_) * score_count_];
          const std::int64_t dx = ix_ * lattice, dy = iy_ * lattice;
          const std::uint32_t n = score_count_;
          for (; scored < n && static_cast<std::int64_t>(hits + (n - scored)) > to_beat; ++scored) {
            hits += grid->near_cell(cells[scored].x + dx, cells[scored].y + dy, plane[scored]) ? 1u : 0u;
          }
        }
        for (; lattice <= 0 && scored < score_count_ && static_cast<std::int64_t>(hits + (score_count_ - scored)) > to_beat;
             ++scored) {
          const Vec3f& p = score_pts_[scored];
          const Vec3f q(static_cast<float>(c * p.x() - s * p.y() + x), static_cast<float>(s * p.x() + c * p.y() + y),
                        static_cast<float>(p.z() + result_.ground_z));
          hits += (grid != nullptr ? grid->near(q) : map.tree->any_within(q, d2max_f, &work_)) ? 1u : 0u;
        }
        const std::uint32_t per_unit = lattice > 0 ? kLatticeLookupsPerUnit : kGridLookupsPerUnit;
        work_ += kHypothesisUnits + (grid != nullptr ? (scored + per_unit - 1) / per_unit : scored);
        if (scored < score_count_) continue;  // pruned
        keep_distinct_best(top_, Candidate{static_cast<double>(hits) / score_count_, x, y, yaw}, params_);
      }
    }
  }
  phase_ = params_.climb_points > 0 ? Phase::kClimb : Phase::kRefine;
  candidate_ = 0;
  refining_fine_ = false;
  run_started_ = false;
}

// One kept hypothesis climbed to its basin's bottom (basin_climb.hpp); after the last, the list
// ranked again, one per basin first.
void PoseSearch::climb_candidate(const IcpTarget& map, ClimbScratch& scratch) {
  if (candidate_ >= kPoseSearchRefine) {
    // Climbs that end a step apart (diagonal included) found the same bottom.
    rank_basins(top_, params_.basin_distance, params_.distinct_yaw, 1.5 * params_.climb_step);
    phase_ = Phase::kRefine;
    candidate_ = 0;
    return;
  }
  Candidate& h = top_[candidate_++];
  if (!(h.score >= 0.0)) return;
  const ProximityGrid* grid = grid_ != nullptr && grid_->ready() && grid_->valid() ? grid_ : nullptr;
  const BasinClimbParams cp{.points = params_.climb_points, .rounds = params_.climb_rounds, .step = params_.climb_step,
                            .min_height = params_.min_height, .score_distance = params_.score_distance,
                            .ground_z = result_.ground_z};
  ClimbWork w;
  climb_pose(ClimbTarget{scan(), grid, grid != nullptr ? nullptr : map.tree}, h, cp, scratch, &w);
  work_ += grid != nullptr ? (w.lookups + kGridLookupsPerUnit - 1) / kGridLookupsPerUnit : w.lookups + w.node_visits;
  work_ += kHypothesisUnits;
}

// Grid cells between neighbouring hypotheses when the lattice form applies (step a whole number
// of the grid's cells, the table large enough), the scratch's table filled for this job; else 0.
std::int64_t PoseSearch::lattice_step(const ProximityGrid& grid, PoseSearchScratch& scratch) {
  const double ratio = params_.step / grid.cell();
  const double whole = std::floor(ratio + 0.5);
  if (!(whole >= 1.0 && whole <= 1e6 && std::abs(ratio - whole) <= 1e-9 * whole)) return 0;
  if (static_cast<std::size_t>(params_.yaw_steps) * score_count_ > kPoseSearchLatticeCells) return 0;
  if (!lattice_filled_ || scratch.lattice_owner != this) {
    for (std::uint32_t k = 0; k < params_.yaw_steps; ++k) {
      const double yaw = 2.0 * det::kPi * k / params_.yaw_steps;
      const bool tabled = k < kMaxYawTable;
      const double c = tabled ? yaw_cos_[k] : det::cos(yaw);
      const double s = tabled ? yaw_sin_[k] : det::sin(yaw);
      for (std::uint32_t i = 0; i < score_count_; ++i) {
        const Vec3f& p = score_pts_[i];
        std::int64_t x = 0, y = 0;
        grid.cell_xy(c * p.x() - s * p.y() + center_.x(), s * p.x() + c * p.y() + center_.y(), x, y);
        // Beyond +-2^30 cells is far outside the grid whatever the offset (<= 2^21 cells).
        constexpr std::int64_t kFar = std::int64_t{1} << 30;
        scratch.lattice[k * score_count_ + i] = {static_cast<std::int32_t>(x < -kFar ? -kFar : (x > kFar ? kFar : x)),
                                                 static_cast<std::int32_t>(y < -kFar ? -kFar : (y > kFar ? kFar : y))};
      }
    }
    scratch.lattice_owner = this;
    lattice_filled_ = true;
  }
  return static_cast<std::int64_t>(whole);
}

// Hits of the kept list's worst entry (scores are hits / score_count_, exact for the integer
// counts), -1 while the list has room: a hypothesis needs more hits than this to be kept.
std::int64_t PoseSearch::worst_kept_hits() const {
  const double worst = top_[kPoseSearchRefine - 1].score;
  if (!(worst >= 0.0)) return -1;
  return static_cast<std::int64_t>(std::floor(worst * score_count_ + 0.5));
}

// Refine the best hypotheses (coarse then fine ICP). Aliased poses along a straight canyon
// reach similar fitness at a coarse threshold but not the fine RMSE of the true pose.
void PoseSearch::refine_candidate(const IcpTarget& map, std::uint64_t stop) {
  const std::uint32_t count = refine_count();
  if (candidate_ >= count) {
    phase_ = Phase::kSelect;
    candidate_ = 0;
    best_tight_ = -1.0;
    winner_ = kPoseSearchRefine;
    return;
  }
  const Candidate& cand = top_[candidate_];
  RegistrationResult& refined = refined_[candidate_];
  if (cand.score < 0.0 || cand.score < params_.refine_min_score_ratio * top_[0].score) {
    refined.status = RegistrationStatus::kDidNotConverge;
    ++candidate_;
    return;
  }
  if (from_given_ && !refining_fine_) {  // a known pose: straight to the fine ICP
    coarse_ = RegistrationResult{};
    coarse_.status = RegistrationStatus::kOk;
    coarse_.transform = given_[candidate_];
    refining_fine_ = true;
  }
  const IcpParams& icp_params = refining_fine_ ? params_.fine_icp : params_.icp;
  if (!run_started_) {
    const Mat4d initial = refining_fine_ ? coarse_.transform : pose_of(cand.x, cand.y, result_.ground_z, cand.yaw);
    icp_begin(run_, refine_scan(), map, initial, icp_params, hints());
    run_started_ = true;
  }
  const std::uint64_t before = run_.work;
  const bool finished = icp_continue(run_, refine_scan(), map, icp_params, ~std::uint32_t{0}, hints(),
                                     stop > work_ ? stop - work_ : 1);
  work_ += run_.work - before;
  if (!finished) return;
  run_started_ = false;
  if (!refining_fine_) {
    coarse_ = run_.result;
    if (coarse_.ok()) {
      // The best-scored hypothesis' coarse ICP: nearer its basin's bottom than the hypothesis.
      if (candidate_ == 0 && !from_given_) {
        leader_coarse_ = coarse_.transform;
        leader_coarse_ok_ = true;
      }
      refining_fine_ = true;
      return;
    }
    refined.status = RegistrationStatus::kDidNotConverge;
    ++candidate_;
    return;
  }
  refining_fine_ = false;
  refined = run_.result;
  if (refined.ok() && params_.use_yaw_prior &&
      std::abs(det::wrap_pi(yaw_of(refined.transform.topLeftCorner<3, 3>()) - params_.yaw_prior)) >
          params_.yaw_prior_tolerance) {
    refined.status = RegistrationStatus::kDidNotConverge;  // slid out of the prior
  }
  if (refined.ok() && params_.max_offset > 0.0 && !from_given_) {
    const double dx = refined.transform(0, 3) - center_.x(), dy = refined.transform(1, 3) - center_.y();
    if (dx * dx + dy * dy > params_.max_offset * params_.max_offset) {
      refined.status = RegistrationStatus::kDidNotConverge;  // slid out of the region
    }
  }
  const bool judge = refined.ok() && (params_.provisional || params_.clear_margin);
  if (judge) judge_refined(map, refined, candidate_);
  const bool sets_margin = refined.ok() && (!params_.clear_margin || rated_[candidate_] == 1);
  if (sets_margin && refined.fitness > best_fitness_) best_fitness_ = refined.fitness;
  ++candidate_;
}

// A refined pose judged as it comes by the selection's own measures (rays, tight fitness), kept
// for the selection (select_candidate), which would compute the same; with params_.provisional
// the best so far, for a caller that outputs something while the search goes on.
void PoseSearch::judge_refined(const IcpTarget& map, const RegistrationResult& refined, std::uint32_t i) {
  conflicts_[i] = -1.0;
  tight_[i] = -1.0;
  const bool rated = rate_pose(map, refined.transform, conflicts_[i], tight_[i]);
  rated_[i] = rated ? 1 : 0;
  if (!params_.provisional || !rated) return;
  const std::uint32_t b = provisional_;
  if (b == kPoseSearchRefine ||
      replaces_best_so_far({tight_[i], conflicts_[i]}, {tight_[b], conflicts_[b]}, params_.provisional_ambiguity,
                           params_.provisional_conflict_ratio, params_.provisional_conflict_margin)) {
    provisional_ = i;
  }
}

// The selection's measures of one refined pose, both counted as work: the ray conflict ratio
// (when max_conflicts is on) and, unless its rays cross the map (false), the tight fitness.
bool PoseSearch::rate_pose(const IcpTarget& map, const Mat4d& pose, double& conflicts, double& tight) {
  if (params_.max_conflicts > 0.0) {
    // The scoring grid answers for free space while the map is the one it was built on.
    const bool same_map = grid_ != nullptr && map.points.data() == grid_source_.data() && map.points.size() == grid_source_.size();
    conflicts = ray_conflict_ratio(scan(), map, pose, result_.ground_z, params_, &work_, same_map ? grid_ : nullptr);
    if (conflicts > params_.max_conflicts) return false;
  }
  const RegistrationResult fit = evaluate_registration(scan(), map, pose, params_.select_distance);
  tight = fit.fitness;
  work_ += scan_count_ + fit.node_visits;
  return true;
}

// The best-scored hypothesis stands in (provisional_scored) until its own refinement refutes it:
// its coarse or fine ICP finds no basin there, the pose slides out of the region or the yaw prior,
// or its rays cross the map's surfaces. On a sparse map the leader among thousands of hypotheses
// is an alias as often as the truth, and these checks are the first evidence either way.
bool PoseSearch::provisional(Mat4d& pose) const {
  // Refined poses first: the best-scored hypothesis alone can be an alias along the street
  // (algo/TUNING.md, start-up); it stands in only with provisional_scored, once scoring is over.
  if (provisional_ < kPoseSearchRefine && tight_[provisional_] > 0.0) {
    pose = refined_[provisional_].transform;
    return true;
  }
  if (!params_.provisional_scored || phase_ == Phase::kScore || phase_ == Phase::kClimb || phase_ == Phase::kDone ||
      !(top_[0].score >= 0.0)) {
    return false;
  }
  // The leader's refinement is over (the next candidate's began, or the selection) and did not
  // rate it: refuted (rated_ stays -1 for a pose whose ICP failed or slid out).
  const bool leader_refined = phase_ == Phase::kSelect || candidate_ > 0;
  if (leader_refined && rated_[0] != 1) return false;
  // Its coarse ICP's result; while that ICP runs, its latest estimate (nearer the basin's bottom
  // than the hypothesis); before its first pass, the hypothesis.
  const bool coarse_under_way = !from_given_ && candidate_ == 0 && !refining_fine_ && run_started_ && run_.passes > 0;
  pose = leader_coarse_ok_   ? leader_coarse_
         : coarse_under_way ? run_.transform
                            : pose_of(top_[0].x, top_[0].y, result_.ground_z, top_[0].yaw);
  return true;
}

// The winner: the highest fitness at a tight threshold (an aliased pose explains the scan at
// 1 m but not at 0.3 m; inlier RMSE at a loose threshold does not separate them), among the
// poses whose rays do not cross the map's surfaces (max_conflicts). One candidate per call.
void PoseSearch::select_candidate(const IcpTarget& map) {
  const std::uint32_t count = refine_count();
  if (candidate_ >= count) {
    finish();
    return;
  }
  const std::uint32_t i = candidate_++;
  const RegistrationResult& r = refined_[i];
  const bool judged = rated_[i] >= 0;  // by judge_refined: conflicts_[i], tight_[i] hold its measures
  const bool eligible = in_margin(i);
  if (!judged || !eligible) {
    tight_[i] = -1.0;
    conflicts_[i] = -1.0;
  }
  if (!eligible) return;
  const bool rated = judged ? rated_[i] == 1 : rate_pose(map, r.transform, conflicts_[i], tight_[i]);
  if (!rated) {
    ++result_.conflict_rejected;
    return;
  }
  if (tight_[i] > best_tight_) {
    best_tight_ = tight_[i];
    winner_ = i;
  }
}

bool PoseSearch::in_margin(std::uint32_t i) const {
  return refined_[i].ok() && refined_[i].fitness >= best_fitness_ - kPoseSearchFitnessMargin;
}

// The next step does no work: the refinement's end, or a selection step that rates no pose
// (rate_pose is the selection's only work).
bool PoseSearch::next_step_is_free() const {
  if (phase_ == Phase::kRefine) return candidate_ >= refine_count();
  return phase_ == Phase::kSelect && (candidate_ >= refine_count() || rated_[candidate_] >= 0 || !in_margin(candidate_));
}

void PoseSearch::finish() {
  phase_ = Phase::kDone;
  if (winner_ == kPoseSearchRefine) return;
  result_.best = refined_[winner_];
  result_.best_score = top_[winner_].score;
  result_.best_tight_fitness = best_tight_;
  // Runner-up: the best candidate that is a different pose (not the same basin).
  for (std::uint32_t i = 0; i < refine_count(); ++i) {
    if (i == winner_ || tight_[i] < 0.0) continue;
    const Mat4d d = se3_inverse(refined_[winner_].transform) * refined_[i].transform;
    const double dist = std::sqrt(d(0, 3) * d(0, 3) + d(1, 3) * d(1, 3));
    const double dyaw = std::abs(det::wrap_pi(yaw_of(d.topLeftCorner<3, 3>())));
    if (dist < params_.distinct_distance && dyaw < params_.distinct_yaw) continue;
    if (tight_[i] > result_.runner_up_tight_fitness) {
      result_.runner_up_tight_fitness = tight_[i];
      result_.runner_up = refined_[i];
      result_.runner_up_conflicts = conflicts_[i];
    }
  }
  result_.best_conflicts = conflicts_[winner_];
}

std::uint32_t PoseSearch::finalists(std::span<Mat4d> out) const {
  if (phase_ != Phase::kDone || winner_ == kPoseSearchRefine || out.empty()) return 0;
  std::uint32_t n = 0;
  out[n++] = refined_[winner_].transform;
  for (std::uint32_t i = 0; i < refine_count() && n < out.size(); ++i) {
    if (i != winner_ && tight_[i] >= 0.0) out[n++] = refined_[i].transform;
  }
  return n;
}

}  // namespace v2xloc
