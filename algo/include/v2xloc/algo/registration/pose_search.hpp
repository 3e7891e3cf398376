// GNSS-seeded global pose search: an exhaustive, bounded multi-hypothesis search over position
// (a grid inside the GNSS uncertainty disc) and heading (all yaws), for a vehicle on a road
// (roll = pitch = 0, body origin on the ground). Each hypothesis is scored by the fraction of a
// fixed subsample of above-ground scan points that land within score_distance of the map; the
// best few climb to their basins' bottoms (basin_climb.hpp), are ranked again on more points,
// and those near the best are refined by ICP. Used when FPFH + RANSAC cannot decide: in a straight street
// canyon the mirrored pose matches the features as well as the true one, and far from the
// intersection the infrastructure map is too sparse for descriptors.
// Work is bounded by the grid size: hypotheses <= (2 r / step + 1)^2 * yaw_steps, each costing
// score_points nearest-neighbour queries; the ray check adds <= kPoseSearchRefine *
// kPoseSearchMaxConflictRays * kPoseSearchMaxRaySteps bounded-radius queries.
// Work is counted in units of about one k-d tree node visit (kPoseSearchWorkUnit instructions):
// the nodes the queries actually visit, plus one unit per point a pass transforms and accumulates,
// so a slice costs the same instructions whether its queries are cheap (near the map) or dear (a
// wrong pose, a sparse map, noise).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/registration/basin_climb.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/search/proximity_grid.hpp"
#include "v2xloc/algo/registration/registration_result.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

inline constexpr std::uint32_t kPoseSearchRefine = 10;  // hypotheses refined by ICP (at most)
inline constexpr std::uint32_t kPoseSearchMaxConflictRays = 512;
inline constexpr std::uint32_t kPoseSearchMaxRaySteps = 256;  // per ray (128 m at 0.5 m)
// [0-1 fitness] refined poses more than this below the best ICP fitness (at the loose ICP gate) are
// not judged further: inside the margin the loose fitness cannot tell the truth from an alias (both
// explain the scan at 1 m), so the tight fitness (select_distance) decides.
inline constexpr double kPoseSearchFitnessMargin = 0.1;
// [instructions] one work unit: a k-d tree node visit with its share of leaf tests, or one
// point's transform and accumulation. Callgrind, x86-64 -O2, whole search slices: 77-127 per unit
// in a synthetic canyon searched from a 30 m-wrong fix, ~93 on Sim 0 / 4_infra_2_agent.
inline constexpr double kPoseSearchWorkUnit = 110.0;

struct PoseSearchParams {
  double radius = 20.0;            // [m] search disc around the GNSS fix
  double step = 2.5;               // [m] position grid spacing
  std::uint32_t yaw_steps = 48;    // [headings] over 360 deg (48: 7.5 deg apart)
  std::uint32_t score_points = 256;  // [points] scan points scored per hypothesis (at most 512 are used)
  double score_distance = 1.0;     // [m] a score point within this of the map is a hit
  double min_height = 0.5;         // [m] scan points below this (body frame) are ground: not scored
  double ground_margin = 10.0;     // [m] road height taken from the map within radius + this
  std::uint32_t max_hypotheses = 40000;  // [hypotheses] hard cap (worst-case time)
  IcpParams icp{};                 // coarse refinement of the best hypotheses
  IcpParams fine_icp{};            // then fine ICP of each coarse result
  // [m] the winner has the highest fitness at this tight threshold, among the refined poses within
  // kPoseSearchFitnessMargin of the best (loose) fitness
  double select_distance = 0.3;
  double distinct_distance = 2.0;  // [m] a runner-up farther than this (or distinct_yaw) is
  double distinct_yaw = 0.17;      // [rad] another basin: its score measures the ambiguity
  // [0-1] negative evidence: refined poses whose fraction of scan rays crossing a map surface
  // exceeds this are not candidates (0: off, nothing computed). A ray crosses a surface when a map
  // point lies within conflict_radius of a sample taken every conflict_step along it, ending
  // conflict_margin before the return; rays are above-ground points beyond conflict_min_range.
  // Fitness counts returns that land on the map and cannot see a pose whose rays go through walls
  // (a street's facades repeat along it, the cross street's opening does not). Measured: TUNING.md.
  double max_conflicts = 0.0;
  // The selection's fitness margin (kPoseSearchFitnessMargin) is measured from the best refined
  // pose whose rays do not cross the map, each refined pose rated as it comes: an alias that looks
  // through walls is no candidate, and on a sparse map its loose fitness can exceed the truth's by
  // more than the margin (false: from the best refined pose, rays unchecked).
  bool clear_margin = false;
  Vec3d sensor_in_body{0.0, 0.0, 1.8};   // [m] ray origin (the LiDAR) in the body frame
  std::uint32_t conflict_rays = 128;     // [rays] per pose, <= kPoseSearchMaxConflictRays
  double conflict_step = 0.5;            // [m] sample spacing along a ray
  double conflict_radius = 0.25;         // [m] ~ map voxel
  double conflict_margin = 1.5;          // [m] the return's own surface and its noise
  double conflict_min_range = 5.0;       // [m] shorter returns cast no ray
  // [m] samples start this far from the sensor: the infrastructure sees the ego vehicle, so the
  // map may hold its body (and it is where the vehicle truly is: the truth would pay for it).
  double conflict_start = 3.0;
  // Optional heading prior (e.g. the odometry track fitted to the GNSS track): hypotheses and
  // refined results farther than yaw_prior_tolerance from yaw_prior are not considered.
  bool use_yaw_prior = false;
  double yaw_prior = 0.0;            // [rad]
  double yaw_prior_tolerance = 1.05; // [rad] (60 deg)
  // [m] refined poses farther than this horizontally from the search's centre are no candidates,
  // as those outside the yaw prior (0: off; a start-up search's region, which its acceptance
  // checks: an alias the ICP pulled outside would only be refused after winning the selection)
  double max_offset = 0.0;
  std::uint32_t refine_candidates = 10;  // best distinct hypotheses refined (<= kPoseSearchRefine)
  // [points] the ICPs refine on an even subsample of at most this many scan points (0: all); the
  // selection (rays, tight fitness) still judges every scan point. The ICP only has to reach the
  // basin's bottom; the tight fitness that tells an alias from the truth wants the many points.
  std::uint32_t refine_points = 0;
  // Judge each refined pose as it comes (rays, tight fitness) so that provisional() names the
  // best so far while the search runs over several periods (costs ~1 fitness pass a candidate).
  bool provisional = false;
  // ... and before any is refined, once every hypothesis is scored (and climbed), the best-scored
  // one (~0.1-1.2 m and half a yaw step from its basin's bottom; power-up, where the alternative
  // is the GNSS fix), replaced by its coarse ICP's result once that converged; none once its own
  // refinement refutes it (no basin, outside the region or prior, rays through the map).
  bool provisional_scored = false;
  // [work units] of that coarse ICP run in the power-up scoring slice whatever the budget; the
  // rest takes the budget's slices (~110 instructions a unit).
  std::uint64_t power_up_coarse_work = 150000;
  // A refined pose whose tight fitness is within this ratio of the best so far (either side) is a
  // near-tie for provisional(): the one whose rays clearly cross fewer mapped surfaces
  // (clearly_fewer_conflicts with the two below) stands in, else the higher (0: the higher alone).
  // The start-up search sets its own ambiguity rule here, so the pose it outputs while it runs is
  // the one its final selection would keep from the two.
  double provisional_ambiguity = 0.0;     // [0-1]
  double provisional_conflict_ratio = 2.0;   // [ratio]
  double provisional_conflict_margin = 0.04; // [0-1]
  // Scoring on a proximity grid (set_proximity_grid): a score point hits when a map point lies
  // in a cell within ceil(grid_reach / grid_cell) cells of its own on every axis, a cube that
  // stands for the score_distance sphere (1 m cells, reach 1: 3 m cube ~ the 2 m sphere's volume).
  float grid_cell = 1.0f;          // [m]
  float grid_reach = 1.0f;         // [m]
  // Basin climb (basin_climb.hpp; 0 points: off): once every hypothesis is scored, each kept one
  // (kPoseSearchRefine) climbs to its basin's bottom, scored on climb_points above-ground points,
  // at most climb_rounds moves of climb_step; then they are ranked again, each basin's best
  // (basin_distance, distinct_yaw) ahead of the rest, before the best are refined.
  std::uint32_t climb_points = 0;
  std::uint32_t climb_rounds = 4;
  double climb_step = 1.0;         // [m]
  double basin_distance = 4.5;     // [m]
  // [0-1] hypotheses scoring below this fraction of the best are not refined (0: all
  // refine_candidates are): with the climb, the true basin outscores its aliases by 15-35 %.
  double refine_min_score_ratio = 0.0;
};

struct PoseSearchResult {
  RegistrationResult best;         // refined best hypothesis (status kOk when found)
  std::uint32_t hypotheses = 0;    // scored
  double best_score = 0.0;         // coarse score of the winning hypothesis
  double ground_z = 0.0;           // [m] map ground height used for the hypotheses
  double best_tight_fitness = 0.0;       // winner's fitness at select_distance
  double runner_up_tight_fitness = 0.0;  // best other basin (0 when none): ambiguity check
  RegistrationResult runner_up;          // that basin's refined pose (status kOk when found)
  double best_conflicts = -1.0;          // ray conflict ratio of best / runner-up (-1: not computed)
  double runner_up_conflicts = -1.0;
  std::uint32_t conflict_rejected = 0;   // refined poses dropped for their ray conflicts
  std::uint32_t scan_points_dropped = 0; // beyond config::kMaxSearchPoints (not searched)
};


// The ray conflict ratio above for one pose (world_T_body); -1 when no ray qualifies.
// work (optional): incremented by the work units spent (one per sample plus the nodes visited).
// free_space (optional): a proximity grid over the same map points, reach >= conflict_radius;
// samples it proves empty skip the k-d tree (the same ratio).
double ray_conflict_ratio(std::span<const Vec3f> scan_body, const IcpTarget& map, const Mat4d& pose,
                          double ground_z, const PoseSearchParams& params, std::uint64_t* work = nullptr,
                          const ProximityGrid* free_space = nullptr);

// Of two poses' ray conflict ratios, the clearly lower: 0 (a's) or 1 (b's) when the other is at
// least ratio x it and margin above it; -1 when neither is (too close, or a ratio unchecked).
int clearly_fewer_conflicts(double conflicts_a, double conflicts_b, double ratio, double margin);

// A rated pose (tight fitness, conflict ratio) against the best so far: whether it takes the
// best's place. The higher tight fitness does, unless the two are a near-tie (the lower at least
// `ambiguity` x the higher; 0: never) that clearly_fewer_conflicts decides.
struct RatedPose {
  double tight = 0.0;
  double conflicts = -1.0;  // < 0: unchecked
};
bool replaces_best_so_far(const RatedPose& candidate, const RatedPose& best, double ambiguity, double conflict_ratio,
                          double conflict_margin);

// [m] height bin of road_height: the road height (the hypotheses' z) is a bin centre, within
// 0.1 m of the road's points, far inside the coarse ICP's gate, which refines it.
inline constexpr double kRoadHeightBin = 0.2;
// [m] road_height's histogram spans this above and below the reference height (400 bins):
// road_height_near centres it on the mean height of the map nearby, so the road lies inside.
inline constexpr double kRoadHeightHalfWindow = 40.0;

// Height of the road surface near `center`: the most populated kRoadHeightBin height bin (within
// +-kRoadHeightHalfWindow of center.z) of the map points within `radius` horizontally. False when
// fewer than min_points fall in that bin (the map does not reach there); height is then center.z.
bool road_height(std::span<const Vec3f> map, const Vec3d& center, double radius, double& height,
                 std::uint32_t min_points = 1);

// The same without a height prior (a canyon's GNSS altitude can be tens of metres off): the
// histogram is centred on the mean height of the map points within `radius` of center's x, y
// (moved by whole bins from center.z). PoseSearch uses this one.
bool road_height_near(std::span<const Vec3f> map, const Vec3d& center, double radius, double& height,
                      std::uint32_t min_points = 1);

class PoseSearch;

// One score point's proximity-grid cell at one heading, the hypothesis at the search's centre
// (the lattice form of scoring, pose_search.cpp).
struct PoseSearchLatticeCell {
  std::int32_t x = 0, y = 0;
};
// [cells] headings x score points the lattice table holds (the localizer's 24 x 64 use 1,536);
// a larger search scores point by point.
inline constexpr std::size_t kPoseSearchLatticeCells = 4096;

// What a PoseSearch job works in while it steps, owned by the caller (44 KiB): the jobs of one
// thread may share one (the localizer's start-up search and basin audit do). The lattice table is
// filled for one job at a time; a job that finds another's there fills it again (the same
// values), so sharing changes no result. The climb's points are filled anew by every climb.
struct PoseSearchScratch {
  PoseSearchLatticeCell lattice[kPoseSearchLatticeCells];
  const PoseSearch* lattice_owner = nullptr;  // the job the table is filled for
  ClimbScratch climb;
};

// The search as a job spread over several periods (start-up, basin audit): start() copies the
// scan (<= config::kMaxSearchPoints points) and takes the road height; each step() runs until
// `budget` work units are spent (scored hypotheses, ICP passes, ray checks, fitness passes; one
// of them is never split, so a step overruns by at most one) and returns true when result() is
// final. start() counts its own work (road height, proximity grid) towards the first step. Run to
// completion it is exactly run(). The map may be swapped between steps (a rebuilt map of the
// same scene): ICP hints are only seeds, results stay exact for the map given. Each instance is
// independent of every other (no state outside the object and the scratch its steps are given).
class PoseSearch {
 public:
  // The search in one piece: start(), then step() without a budget until done.
  // Work: hypotheses * score_points bounded nearest queries, then 2 * kPoseSearchRefine ICPs over
  // scan_body (<= config::kMaxSearchPoints points are searched, the rest counted).
  const PoseSearchResult& run(std::span<const Vec3f> scan_body, const IcpTarget& map, const Vec3d& center,
                              const PoseSearchParams& params, PoseSearchScratch& scratch);
  void start(std::span<const Vec3f> scan_body, const IcpTarget& map, const Vec3d& center,
             const PoseSearchParams& params);
  // Re-decides between known poses (world_T_body, e.g. a finished search's finalists carried to
  // a later scan by the odometry): no scoring, each pose refined by the fine ICP only, then the
  // same selection (ray check, tight fitness, runner-up). At most kPoseSearchRefine poses.
  void start_from_poses(std::span<const Vec3f> scan_body, const IcpTarget& map, std::span<const Mat4d> poses,
                        double ground_z, const PoseSearchParams& params);
  // score_whole: the scoring phase and the basin climb, if under way, finish in this step
  // whatever the budget. scratch: the lattice table and the climb's points (any job's).
  bool step(const IcpTarget& map, PoseSearchScratch& scratch, std::uint64_t budget, bool score_whole = false);
  // Score hypotheses on this caller-owned proximity grid (proximity_grid.hpp), built by start()
  // over the searched region, instead of the map's k-d tree (nullptr: the tree).
  void set_proximity_grid(ProximityGrid* grid) { grid_ = grid; }
  bool done() const { return phase_ == Phase::kDone; }
  const PoseSearchResult& result() const { return result_; }
  std::uint64_t work() const { return work_; }  // work units so far (kPoseSearchWorkUnit)
  std::span<const Vec3f> scan() const { return {scan_, scan_count_}; }
  // The ICP's subsample: the first refine_count_ points of scan() (copy_scan puts them there).
  std::span<const Vec3f> refine_scan() const { return {scan_, refine_count_}; }
  // The refined poses that reached the selection (not dropped by fitness or rays), winner
  // first; valid once done(). Returns how many were written (<= out.size()).
  std::uint32_t finalists(std::span<Mat4d> out) const;
  // With params.provisional: the best pose refined so far (world_T_body); false before any
  // (with provisional_scored: the best-scored hypothesis once scoring is over).
  bool provisional(Mat4d& pose) const;

 private:
  enum class Phase : std::uint8_t { kScore, kClimb, kRefine, kSelect, kDone };
  static constexpr std::uint32_t kMaxScorePoints = 512;
  void score_hypotheses(const IcpTarget& map, std::uint64_t stop, PoseSearchScratch& scratch);
  std::int64_t worst_kept_hits() const;
  void climb_candidate(const IcpTarget& map, ClimbScratch& scratch);
  std::int64_t lattice_step(const ProximityGrid& grid, PoseSearchScratch& scratch);
  void refine_candidate(const IcpTarget& map, std::uint64_t stop);
  void select_candidate(const IcpTarget& map);
  bool in_margin(std::uint32_t i) const;
  bool next_step_is_free() const;
  void finish();
  bool copy_scan(std::span<const Vec3f> scan_body, const IcpTarget& map);
  void build_grid(const IcpTarget& map);
  void judge_refined(const IcpTarget& map, const RegistrationResult& refined, std::uint32_t i);
  bool rate_pose(const IcpTarget& map, const Mat4d& pose, double& conflicts, double& tight);
  std::uint32_t refine_count() const {
    return params_.refine_candidates < kPoseSearchRefine ? params_.refine_candidates : kPoseSearchRefine;
  }
  std::span<std::uint32_t> hints() { return {hints_, refine_count_}; }

  PoseSearchParams params_{};
  ProximityGrid* grid_ = nullptr;
  std::span<const Vec3f> grid_source_{};  // the map points grid_ was built on
  Vec3d center_ = Vec3d::Zero();
  PoseSearchResult result_{};
  Phase phase_ = Phase::kDone;
  std::uint64_t work_ = 0;
  std::uint64_t step_from_ = 0;                   // work_ when the current step began
  bool lattice_filled_ = false;                   // this job filled a scratch's lattice table (lattice_step)
  Vec3f scan_[config::kMaxSearchPoints];
  std::uint32_t hints_[config::kMaxSearchPoints];
  std::size_t scan_count_ = 0;
  std::size_t refine_count_ = 0;                  // leading scan_ points the ICPs use
  Vec3f score_pts_[kMaxScorePoints];
  std::uint32_t score_count_ = 0;
  static constexpr std::uint32_t kMaxYawTable = 720;  // headings whose cos / sin start() tabulates
  double yaw_cos_[kMaxYawTable] = {};
  double yaw_sin_[kMaxYawTable] = {};
  int cells_ = 0, iy_ = 0, ix_ = 0;               // scoring cursor: grid row, column ...
  std::uint32_t yaw_index_ = 0;                   // ... and heading
  PoseSearchCandidate top_[kPoseSearchRefine];
  RegistrationResult refined_[kPoseSearchRefine];
  RegistrationResult coarse_{};
  Mat4d given_[kPoseSearchRefine];                // start_from_poses: the fine ICP's starts
  bool from_given_ = false;
  IcpRun run_{};
  bool run_started_ = false;
  bool refining_fine_ = false;
  std::uint32_t candidate_ = 0;                   // climb / refinement / selection cursor
  double best_fitness_ = 0.0;
  double tight_[kPoseSearchRefine] = {};
  double conflicts_[kPoseSearchRefine] = {};
  double best_tight_ = -1.0;
  // Refined candidate i judged by judge_refined (its measures already in conflicts_[i] and
  // tight_[i]): -1 not judged, 0 its rays cross the map, 1 rated. The selection reuses them.
  std::int8_t rated_[kPoseSearchRefine] = {};
  std::uint32_t provisional_ = kPoseSearchRefine;  // the best rated candidate so far (kPoseSearchRefine: none)
  bool leader_coarse_ok_ = false;                 // top_[0]'s coarse ICP converged (provisional_scored)
  Mat4d leader_coarse_ = Mat4d::Identity();
  std::uint32_t winner_ = kPoseSearchRefine;
};

}  // namespace v2xloc
