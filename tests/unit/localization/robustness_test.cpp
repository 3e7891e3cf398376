// The localizer's defences against the failure modes measured on Sim 0 / Sim 3 (issue 4): an
// odometry that slips at a turn's onset (EKF odometry NIS gate, prediction from the vehicle
// signals), a symmetric scene whose 180-degree mirror matches as well as the truth (pose search:
// one hypothesis per basin, heading prior), and a filter that must be dropped (Ekf::reset).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "courtyard_search.hpp"
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/localization/ekf.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/localization/odometry.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"
#include "v2xloc/algo/search/proximity_grid.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {
namespace {

namespace idx = ekf_index;

// A filter turning at 0.65 rad/s (Sim 3's left turn: 6.5 m/s on a 10 m radius), gyro-fed.
std::unique_ptr<Ekf> turning_filter() {
  auto f = std::make_unique<Ekf>();
  EkfState s;
  s.speed = 6.5;
  s.yaw_rate = 0.65;
  EkfVector sd;
  sd << 0.05, 0.05, 0.05, 0.01, 0.1, 0.02, 0.002, 0.01, 0.01, 0.005, 0.01, 0.01, 0.05, 0.05;
  f->initialize(0.0, s, EkfCovariance(sd.cwiseProduct(sd).asDiagonal()));
  for (int k = 1; k <= 10; ++k) EXPECT_EQ(f->on_vehicle_signals(0.01 * k, 6.5, 0.65), EkfFuseStatus::kFused);
  EXPECT_EQ(f->predict_to(0.1), EkfFuseStatus::kFused);
  return f;
}

Mat4d frame_motion(double forward, double dyaw) {
  Mat4d m = Mat4d::Identity();
  m.topLeftCorner<3, 3>() = rot_z(dyaw);
  m(0, 3) = forward;
  return m;
}

TEST(EkfRobustness, SlippedOdometryRateIsRejectedConsistentOneFused) {
  auto f = turning_filter();
  // Under-rotated by 3 deg in one frame (measured at Sim 3's turn before the fix).
  EXPECT_EQ(f->on_odometry(0.1, 0.1, Pose3d(frame_motion(0.65, 0.065 - 0.052))), EkfFuseStatus::kRejectedGate);
  EXPECT_EQ(f->counters().odometry_rejected, 1u);
  EXPECT_NEAR(f->state().yaw_rate, 0.65, 0.01) << "a rejected rate must not move the state";
  EXPECT_EQ(f->on_odometry(0.1, 0.1, Pose3d(frame_motion(0.65, 0.065))), EkfFuseStatus::kFused);
  EXPECT_EQ(f->counters().odometry_fused, 1u);
}

// Odometry frames from t = 0.1 to `until` (10 Hz) on the turn, the vehicle signals between them;
// the frame at `slip_at` under-rotated by 3 deg (measured at Sim 3's turn before the gate).
void turn_with_odometry(Ekf& f, double until, double slip_at) {
  for (int frame = 1; 0.1 * frame <= until + 1e-9; ++frame) {
    const double t = 0.1 * frame;
    if (frame > 1) {
      for (int k = 1; k <= 10; ++k) f.on_vehicle_signals(t - 0.1 + 0.01 * k, 6.5, 0.65);
      f.predict_to(t);
    }
    const bool slipped = std::abs(t - slip_at) < 1e-9;
    f.on_odometry(t, 0.1, Pose3d(frame_motion(0.65, slipped ? 0.065 - 0.052 : 0.065)));
  }
}

TEST(EkfRobustness, SlippedOdometryWindowIsRejectedConsistentOneFused) {
  auto f = turning_filter();
  turn_with_odometry(*f, 1.1, 0.5);  // the chain starts at 0.1 s; its first window ends at 1.1 s
  EXPECT_EQ(f->counters().odometry_rejected, 1u);  // the slipped frame's rate too
  EXPECT_EQ(f->counters().odometry_windows_rejected, 1u);
  EXPECT_EQ(f->counters().odometry_windows_fused, 0u);
  auto g = turning_filter();
  turn_with_odometry(*g, 1.1, -1.0);
  // The slipped frame's own rate was refused too, so a rejected window leaves the heading where the
  // consistent run's fused window put it (the slip, fused, would pull it 4 mrad).
  EXPECT_NEAR(f->state().yaw, g->state().yaw, 5e-5) << "a rejected window must not turn the heading";
  EXPECT_EQ(g->counters().odometry_windows_fused, 1u);
  EXPECT_EQ(g->counters().odometry_windows_rejected, 0u);
  EXPECT_EQ(g->counters().odometry_fused, 11u);  // every frame's speed
}

TEST(EkfRobustness, ResetDropsTheFilterAndKeepsCounters) {
  auto f = turning_filter();
  const std::uint64_t signals = f->counters().signals_fused;
  EXPECT_GT(signals, 0u);
  f->reset();
  EXPECT_FALSE(f->initialized());
  EXPECT_EQ(f->on_gnss(0.2, Vec3d::Zero(), 3.0, 5.0), EkfFuseStatus::kNotInitialized);
  EXPECT_EQ(f->on_registration(0.2, Pose3d::Identity(), PoseCovariance::Identity()),
            EkfFuseStatus::kNotInitialized);
  f->initialize(1.0, EkfState{}, EkfCovariance::Identity());
  EXPECT_TRUE(f->initialized());
  EXPECT_EQ(f->counters().signals_fused, signals) << "counters survive restarts (diagnostics)";
}

// A rectangular courtyard (walls x = +-10, y = +-6, 4 m high) with a ground plane: it matches
// itself turned by 180 degrees about its centre.
std::vector<Vec3f> courtyard(std::mt19937_64& rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Vec3f> pts;
  for (int i = 0; i < 1500; ++i) {
    const float h = 4.0f * u(rng);
    pts.emplace_back(-10.0f + 20.0f * u(rng), 6.0f, h);
    pts.emplace_back(-10.0f + 20.0f * u(rng), -6.0f, h);
  }
  for (int i = 0; i < 800; ++i) {
    const float h = 4.0f * u(rng);
    pts.emplace_back(10.0f, -6.0f + 12.0f * u(rng), h);
    pts.emplace_back(-10.0f, -6.0f + 12.0f * u(rng), h);
  }
  for (int i = 0; i < 1500; ++i) pts.emplace_back(-10.0f + 20.0f * u(rng), -6.0f + 12.0f * u(rng), 0.0f);
  return pts;
}

// The pose-search jobs' scratch, shared by every job here as the localizer's searches share one.
PoseSearchScratch& search_scratch() {
  static PoseSearchScratch scratch;
  return scratch;
}

struct CourtyardTarget {
  std::vector<Vec3f> points;
  std::vector<Vec3f> normals;
  KdTreeStorage<Vec3f, 8192> tree;
};

TEST(PoseSearchRobustness, MirrorIsMeasuredAsRunnerUpAndExcludedByHeadingPrior) {
  std::mt19937_64 rng(7);
  static CourtyardTarget map;  // tree storage: static, not the stack
  map.points = courtyard(rng);
  map.normals.assign(map.points.size(), Vec3f::Zero());
  ASSERT_EQ(map.tree.build(map.points).status, KdBuildStatus::kOk);
  NormalParams np;
  np.radius = 0.8f;
  estimate_normals(map.tree.tree, np, std::span<Vec3f>(map.normals));
  const IcpTarget target{map.points, map.normals, &map.tree.tree};

  // The vehicle at (0.5, -0.5), heading 0.3 rad; its scan is a fresh sample in the body frame.
  Mat4d truth = Mat4d::Identity();
  truth.topLeftCorner<3, 3>() = rot_z(0.3);
  truth(0, 3) = 0.5;
  truth(1, 3) = -0.5;
  const Mat4d inv = se3_inverse(truth);
  std::vector<Vec3f> scan;
  int k = 0;
  for (const Vec3f& p : courtyard(rng)) {
    if (k++ % 4 != 0) continue;  // a sparse scan keeps the test fast under qemu
    const Vec3d q = inv.topLeftCorner<3, 3>() * p.cast<double>() + inv.topRightCorner<3, 1>();
    scan.push_back(q.cast<float>());
  }
  PoseSearchParams sp;
  sp.radius = 4.0;
  sp.step = 1.0;
  sp.yaw_steps = 24;
  sp.score_points = 128;
  sp.icp.method = IcpMethod::kPointToPlane;
  sp.icp.max_correspondence_distance = 1.0;
  sp.fine_icp = sp.icp;
  sp.fine_icp.max_correspondence_distance = 0.3;
  const Vec3d gnss(2.0, 1.0, 0.0);

  static PoseSearch search;
  const PoseSearchResult open = search.run(scan, target, gnss, sp, search_scratch());
  ASSERT_TRUE(open.best.ok());
  // One hypothesis per basin reaches the refinement, so the mirror is there to be measured.
  EXPECT_GT(open.runner_up_tight_fitness, 0.85 * open.best_tight_fitness)
      << "the mirrored pose explains the scan as well: the search must report the ambiguity";

  sp.use_yaw_prior = true;
  sp.yaw_prior = 0.3 + 0.4;  // a prior 23 deg off, well inside +-60 deg
  const PoseSearchResult prior = search.run(scan, target, gnss, sp, search_scratch());
  ASSERT_TRUE(prior.best.ok());
  const Mat4d d = se3_inverse(truth) * prior.best.transform;
  EXPECT_LT(std::hypot(d(0, 3), d(1, 3)), 0.05);
  EXPECT_LT(std::abs(det::wrap_pi(yaw_of(d.topLeftCorner<3, 3>()))), 0.01);
  EXPECT_LT(prior.runner_up_tight_fitness, 0.85 * prior.best_tight_fitness)
      << "with the heading prior the mirror is not a candidate";
  EXPECT_LT(prior.hypotheses, open.hypotheses) << "hypotheses outside the prior are not scored";

  // A canyon fix can be 50 m off vertically (Sim 2's first fix): the hypotheses still sit on the
  // map's road, not at the fix's altitude, and the search finds the same pose.
  const PoseSearchResult high = search.run(scan, target, Vec3d(gnss.x(), gnss.y(), 60.0), sp, search_scratch());
  ASSERT_TRUE(high.best.ok());
  EXPECT_NEAR(high.ground_z, 0.0, 0.11);  // half a 0.2 m bin
  const Mat4d dh = se3_inverse(prior.best.transform) * high.best.transform;
  EXPECT_LT(std::hypot(dh(0, 3), dh(1, 3)), 0.05);
}

// The courtyard as a search target (tree, normals) and a sparse scan of it from `truth`, heading
// 0.3 rad at (0.5, 0): the scene of the pose-search job tests.
struct CourtyardScene {
  CourtyardTarget map;
  IcpTarget target;
  Mat4d truth = Mat4d::Identity();
  std::vector<Vec3f> scan;
};

void build_courtyard_scene(CourtyardScene& c) {
  std::mt19937_64 rng(7);
  c.map.points = courtyard(rng);
  ASSERT_EQ(c.map.tree.build(c.map.points).status, KdBuildStatus::kOk);
  c.map.normals.assign(c.map.points.size(), Vec3f::Zero());
  NormalParams np;
  np.radius = 0.8f;
  estimate_normals(c.map.tree.tree, np, std::span<Vec3f>(c.map.normals));
  c.target = IcpTarget{c.map.points, c.map.normals, &c.map.tree.tree};
  c.truth.topLeftCorner<3, 3>() = rot_z(0.3);
  c.truth(0, 3) = 0.5;
  const Mat4d inv = se3_inverse(c.truth);
  c.scan.clear();
  int k = 0;
  for (const Vec3f& p : courtyard(rng)) {
    if (k++ % 4 != 0) continue;
    c.scan.push_back((inv.topLeftCorner<3, 3>() * p.cast<double>() + inv.topRightCorner<3, 1>()).cast<float>());
  }
}

using testing::courtyard_search_params;

// The start-up search and the basin audit run as a job over several periods: stepped with a
// small query budget it reaches exactly run()'s result, and no step overruns its budget
// by more than one indivisible unit (a hypothesis, an ICP pass, one candidate's ray check).
TEST(PoseSearchRobustness, SteppedSearchEqualsOneCallAndKeepsItsBudget) {
  static CourtyardScene scene;
  build_courtyard_scene(scene);
  const IcpTarget& target = scene.target;
  const std::vector<Vec3f>& scan = scene.scan;
  PoseSearchParams sp = courtyard_search_params();
  sp.max_conflicts = 0.5;
  sp.sensor_in_body = Vec3d(0.0, 0.0, 1.0);
  const Vec3d gnss(1.5, 0.5, 0.0);
  static PoseSearch one_piece;
  const PoseSearchResult& once = one_piece.run(scan, target, gnss, sp, search_scratch());
  ASSERT_TRUE(once.best.ok());

  static PoseSearch job;
  job.start(scan, target, gnss, sp);
  const std::uint64_t budget = 3000;
  // Largest indivisible unit: a hypothesis (score points), an ICP pass (scan points) or one
  // candidate's rays (<= rays x steps) plus its fitness pass.
  const std::uint64_t unit = kPoseSearchMaxConflictRays * kPoseSearchMaxRaySteps + scan.size();
  int steps = 0;
  for (;;) {
    const std::uint64_t before = job.work();
    const bool done = job.step(target, search_scratch(), budget);
    EXPECT_LE(job.work() - before, budget + unit);
    ++steps;
    if (done) break;
    ASSERT_LT(steps, 100000);
  }
  EXPECT_GT(steps, 10);
  const PoseSearchResult& stepped = job.result();
  EXPECT_EQ(stepped.hypotheses, once.hypotheses);
  EXPECT_EQ(stepped.best.status, once.best.status);
  EXPECT_TRUE(stepped.best.transform == once.best.transform);
  EXPECT_EQ(stepped.best_tight_fitness, once.best_tight_fitness);
  EXPECT_EQ(stepped.runner_up_tight_fitness, once.runner_up_tight_fitness);
  EXPECT_EQ(stepped.best_conflicts, once.best_conflicts);
  EXPECT_EQ(stepped.conflict_rejected, once.conflict_rejected);
}

// A slice whose budget the search's work just fills finishes it: selecting among candidates the
// refinement already judged costs nothing, so it is not left for the next period (a period lost
// between the last refinement and the answer).
TEST(PoseSearchRobustness, ASliceThatHoldsAllTheWorkFinishesTheSearch) {
  static CourtyardScene scene;
  build_courtyard_scene(scene);
  PoseSearchParams sp = courtyard_search_params();
  sp.max_conflicts = 0.5;
  sp.sensor_in_body = Vec3d(0.0, 0.0, 1.0);
  sp.clear_margin = true;  // every refined pose is judged as it comes
  const Vec3d gnss(1.5, 0.5, 0.0);
  static PoseSearch one_piece;
  const PoseSearchResult& once = one_piece.run(scene.scan, scene.target, gnss, sp, search_scratch());
  ASSERT_TRUE(once.best.ok());
  static PoseSearch job;
  job.start(scene.scan, scene.target, gnss, sp);
  EXPECT_TRUE(job.step(scene.target, search_scratch(), one_piece.work()));
  EXPECT_EQ(job.work(), one_piece.work());
  EXPECT_TRUE(job.result().best.transform == once.best.transform);
  EXPECT_EQ(job.result().best_tight_fitness, once.best_tight_fitness);
}

// The confirming search re-decides a finished search's finalists on a later scan: both basins
// of the courtyard's mirror reach it, the same winner comes out at a fraction of the work, and a
// finalist moved 1 m (the odometry's carry error) is pulled back by the fine ICP.
TEST(PoseSearchRobustness, FinalistsAreReDecidedWithoutScoring) {
  static CourtyardScene scene;
  build_courtyard_scene(scene);
  const IcpTarget& target = scene.target;
  const std::vector<Vec3f>& scan = scene.scan;
  const PoseSearchParams sp = courtyard_search_params();
  static PoseSearch full;
  full.start(scan, target, Vec3d(1.5, 0.5, 0.0), sp);
  ASSERT_TRUE(full.step(target, search_scratch(), ~std::uint64_t{0}));
  ASSERT_TRUE(full.result().best.ok());
  Mat4d finalists[kPoseSearchRefine];
  const std::uint32_t n = full.finalists(finalists);
  ASSERT_GE(n, 2u) << "the mirror is a finalist";
  EXPECT_TRUE(finalists[0] == full.result().best.transform) << "winner first";

  // Each finalist 1 m and 3 deg off, as a carry over a few frames might leave it.
  Mat4d nudge = Mat4d::Identity();
  nudge.topLeftCorner<3, 3>() = rot_z(0.05);
  nudge(0, 3) = 1.0;
  for (std::uint32_t i = 0; i < n; ++i) finalists[i] = finalists[i] * nudge;
  static PoseSearch again;
  again.start_from_poses(scan, target, std::span<const Mat4d>(finalists, n), full.result().ground_z, sp);
  ASSERT_TRUE(again.step(target, search_scratch(), ~std::uint64_t{0}));
  const PoseSearchResult& r = again.result();
  ASSERT_TRUE(r.best.ok());
  EXPECT_EQ(r.hypotheses, 0u) << "nothing scored";
  EXPECT_LT(again.work(), full.work());
  const Mat4d d = se3_inverse(full.result().best.transform) * r.best.transform;
  EXPECT_LT(std::hypot(d(0, 3), d(1, 3)), 0.05);
  EXPECT_LT(std::abs(det::wrap_pi(yaw_of(d.topLeftCorner<3, 3>()))), 0.01);
  EXPECT_GT(r.runner_up_tight_fitness, 0.0) << "the mirror is measured again";

  static PoseSearch none;
  none.start_from_poses(scan, target, std::span<const Mat4d>(), 0.0, sp);
  EXPECT_TRUE(none.done());
  EXPECT_FALSE(none.result().best.ok());
  Mat4d out[2];
  EXPECT_EQ(none.finalists(out), 0u);
}

// The candidates' ICPs on an even quarter of the scan (refine_points), the selection on all of
// it: the same basin comes out for a fraction of the ICP work, and the tight fitness is still
// judged on every point (the selection's numbers equal a full-scan evaluation of the winner).
TEST(PoseSearchRobustness, RefineSubsampleFindsTheSamePoseForLessWork) {
  static CourtyardScene scene;
  build_courtyard_scene(scene);
  const IcpTarget& target = scene.target;
  const std::vector<Vec3f>& scan = scene.scan;
  PoseSearchParams sp = courtyard_search_params();
  const Vec3d gnss(1.5, 0.5, 0.0);
  static PoseSearch all_job, sub_job;
  all_job.start(scan, target, gnss, sp);
  ASSERT_TRUE(all_job.step(target, search_scratch(), ~std::uint64_t{0}));
  sp.refine_points = static_cast<std::uint32_t>(scan.size() / 4);
  sub_job.start(scan, target, gnss, sp);
  EXPECT_EQ(sub_job.scan().size(), all_job.scan().size()) << "every point is kept for the selection";
  ASSERT_TRUE(sub_job.step(target, search_scratch(), ~std::uint64_t{0}));
  const PoseSearchResult& a = all_job.result();
  const PoseSearchResult& b = sub_job.result();
  ASSERT_TRUE(a.best.ok());
  ASSERT_TRUE(b.best.ok());
  EXPECT_EQ(a.hypotheses, b.hypotheses) << "scoring does not depend on the ICP subsample";
  EXPECT_LT(sub_job.work(), all_job.work());
  const Mat4d d = se3_inverse(a.best.transform) * b.best.transform;
  EXPECT_LT(std::hypot(d(0, 3), d(1, 3)), 0.05);
  EXPECT_LT(std::abs(det::wrap_pi(yaw_of(d.topLeftCorner<3, 3>()))), 0.01);
  const double tight = evaluate_registration(scan, target, b.best.transform, sp.select_distance).fitness;
  EXPECT_EQ(b.best_tight_fitness, tight) << "the winner is judged on the whole scan";
}

// Scoring on the proximity bitmap (start-up search) instead of the k-d tree: the same pose
// comes out, the hypotheses cost a fraction of the work, and the grid covers the search region.
TEST(PoseSearchRobustness, GridScoredSearchFindsTheTreeScoredPose) {
  static CourtyardScene scene;
  build_courtyard_scene(scene);
  const IcpTarget& target = scene.target;
  const Mat4d& truth = scene.truth;
  const std::vector<Vec3f>& scan = scene.scan;
  PoseSearchParams sp = courtyard_search_params();
  sp.score_distance = 0.5;
  sp.grid_cell = 0.25f;
  sp.grid_reach = 0.5f;
  sp.use_yaw_prior = true;
  sp.yaw_prior = 0.3;
  const Vec3d gnss(1.5, 0.5, 0.0);
  static PoseSearch tree_job, grid_job;
  static ProximityGrid grid;
  tree_job.start(scan, target, gnss, sp);
  ASSERT_TRUE(tree_job.step(target, search_scratch(), ~std::uint64_t{0}));
  grid_job.set_proximity_grid(&grid);
  grid_job.start(scan, target, gnss, sp);
  ASSERT_TRUE(grid.ready());
  ASSERT_TRUE(grid.valid());
  EXPECT_EQ(grid.points_outside(), 0u) << "the courtyard lies inside the searched box";
  EXPECT_GT(grid.points_marked(), 0u);
  ASSERT_TRUE(grid_job.step(target, search_scratch(), ~std::uint64_t{0}));
  const PoseSearchResult& a = tree_job.result();
  const PoseSearchResult& b = grid_job.result();
  ASSERT_TRUE(a.best.ok());
  ASSERT_TRUE(b.best.ok());
  EXPECT_EQ(a.hypotheses, b.hypotheses);
  const Mat4d d = se3_inverse(a.best.transform) * b.best.transform;
  EXPECT_LT(std::hypot(d(0, 3), d(1, 3)), 0.02);
  EXPECT_LT(std::abs(det::wrap_pi(yaw_of(d.topLeftCorner<3, 3>()))), 0.005);
  const Mat4d e = se3_inverse(truth) * b.best.transform;
  EXPECT_LT(std::hypot(e(0, 3), e(1, 3)), 0.05);
  // With grid_reach = score_distance the grid's hits are a superset of the tree's (no false
  // negatives): scores never drop.
  EXPECT_GE(b.best_score, a.best_score);
}

// Two grid-scored jobs with different score points (different lattice tables) stepped in turns
// on one scratch, as the localizer's start-up search and basin audit share one: each finds its
// table taken by the other, fills it again, and ends with the same result, bit for bit, as when
// run alone on a scratch of its own.
TEST(PoseSearchRobustness, JobsSharingAScratchEqualJobsRunAlone) {
  static CourtyardScene scene;
  build_courtyard_scene(scene);
  const IcpTarget& target = scene.target;
  PoseSearchParams sp[2] = {courtyard_search_params(), courtyard_search_params()};
  for (PoseSearchParams& p : sp) {
    p.score_distance = 0.5;
    p.grid_cell = 0.25f;
    p.grid_reach = 0.5f;
    p.climb_points = 128;
  }
  sp[1].score_points = 96;
  const Vec3d centres[2] = {Vec3d(1.5, 0.5, 0.0), Vec3d(-0.5, -1.0, 0.0)};
  static PoseSearch alone[2], shared[2];
  static ProximityGrid grids[4];
  static PoseSearchScratch own[2];
  for (int i = 0; i < 2; ++i) {
    alone[i].set_proximity_grid(&grids[i]);
    alone[i].run(scene.scan, target, centres[i], sp[i], own[i]);
    ASSERT_TRUE(alone[i].result().best.ok());
    shared[i].set_proximity_grid(&grids[2 + i]);
    shared[i].start(scene.scan, target, centres[i], sp[i]);
  }
  bool done[2] = {false, false};
  int turns = 0;
  for (; !(done[0] && done[1]) && turns < 100000; ++turns) {
    const int i = turns % 2;
    if (!done[i]) done[i] = shared[i].step(target, search_scratch(), 500);
  }
  ASSERT_TRUE(done[0] && done[1]);
  EXPECT_GT(turns, 20) << "the jobs alternated while scoring";
  for (int i = 0; i < 2; ++i) {
    const PoseSearchResult& a = alone[i].result();
    const PoseSearchResult& b = shared[i].result();
    EXPECT_EQ(a.hypotheses, b.hypotheses);
    EXPECT_EQ(a.best_score, b.best_score);
    EXPECT_TRUE(a.best.transform == b.best.transform);
    EXPECT_EQ(a.best_tight_fitness, b.best_tight_fitness);
    EXPECT_EQ(a.runner_up_tight_fitness, b.runner_up_tight_fitness);
    EXPECT_EQ(alone[i].work(), shared[i].work());
  }
}

TEST(PoseSearchRobustness, RoadHeightIgnoresTheFixAltitudeAndSaysWhenTheMapIsAbsent) {
  std::mt19937_64 rng(9);
  std::vector<Vec3f> map = courtyard(rng);
  for (Vec3f& p : map) p.z() += 3.0f;  // road at +3 m
  double h = 0.0;
  EXPECT_TRUE(road_height(map, Vec3d(0.0, 0.0, 10.0), 20.0, h, 50));
  EXPECT_NEAR(h, 3.0, 0.11);
  // The fix 60 m high: the road is outside a window around it, not outside one around the map.
  EXPECT_FALSE(road_height(map, Vec3d(0.0, 0.0, 60.0), 20.0, h, 50));
  EXPECT_EQ(h, 60.0);
  EXPECT_TRUE(road_height_near(map, Vec3d(0.0, 0.0, 60.0), 20.0, h, 50));
  EXPECT_NEAR(h, 3.0, 0.11);
  // No map within the radius: not found, and the height is the caller's.
  EXPECT_FALSE(road_height_near(map, Vec3d(500.0, 0.0, 7.0), 20.0, h, 50));
  EXPECT_EQ(h, 7.0);
  // Too few points in the road bin for the caller's threshold.
  EXPECT_FALSE(road_height_near(map, Vec3d(0.0, 0.0, 0.0), 20.0, h, 100000));
}

// A wall across the road at x = 10 (y in [-10, 10], 0-5 m high), the road surface, and a car
// body around the sensor (as the infrastructure maps the ego vehicle).
struct WallTarget {
  std::vector<Vec3f> points;
  KdTreeStorage<Vec3f, 16384> tree;
  void build() {
    for (float y = -10.0f; y <= 10.0f; y += 0.2f) {
      for (float z = 0.0f; z <= 5.0f; z += 0.2f) points.emplace_back(10.0f, y, z);
    }
    for (float x = -20.0f; x <= 30.0f; x += 0.4f) {
      for (float y = -10.0f; y <= 10.0f; y += 0.4f) points.emplace_back(x, y, 0.0f);
    }
    for (float x = -2.0f; x <= 2.0f; x += 0.2f) {
      for (float y = -0.8f; y <= 0.8f; y += 0.2f) points.emplace_back(x, y, 1.5f);  // roof
    }
    ASSERT_EQ(tree.build(points).status, KdBuildStatus::kOk);
  }
};

TEST(PoseSearchRobustness, RayConflictsCountRaysThroughWallsOnly) {
  static WallTarget map;  // tree storage: static, not the stack
  map.build();
  const IcpTarget target{map.points, {}, &map.tree.tree};
  PoseSearchParams p;
  p.sensor_in_body = Vec3d(0.0, 0.0, 1.8);
  auto pose_at = [](double x) {
    Mat4d t = Mat4d::Identity();
    t(0, 3) = x;
    return t;
  };
  // Returns from the wall seen from x = 0 (body frame), plus low returns from the road ahead.
  std::vector<Vec3f> wall_scan;
  for (float y = -6.0f; y <= 6.0f; y += 0.5f) {
    for (float z = 1.0f; z <= 4.0f; z += 1.0f) wall_scan.emplace_back(10.0f, y, z);
  }
  for (float x = 6.0f; x <= 9.0f; x += 0.5f) wall_scan.emplace_back(x, 2.0f, 0.6f);
  // At the true pose no ray crosses a surface: the roof under the sensor and the road under the
  // low rays are not walls.
  EXPECT_EQ(ray_conflict_ratio(wall_scan, target, pose_at(0.0), 0.0, p), 0.0);
  // Shifted back the rays stop short of the wall: nothing contradicts (absence of evidence).
  // (Rays above the car body: at this pose the mapped car is an obstacle ahead.)
  std::vector<Vec3f> high_rays;
  for (const Vec3f& q : wall_scan) {
    if (q.z() >= 2.0f) high_rays.push_back(q);
  }
  EXPECT_EQ(ray_conflict_ratio(high_rays, target, pose_at(-5.0), 0.0, p), 0.0);
  // Shifted forward every wall ray passes through the wall before its return.
  const double ahead = ray_conflict_ratio(wall_scan, target, pose_at(5.0), 0.0, p);
  EXPECT_GT(ahead, 0.7);
  // Returns from behind the wall (seen through an opening the map does not have) conflict too.
  std::vector<Vec3f> behind;
  for (float y = -6.0f; y <= 6.0f; y += 1.0f) behind.emplace_back(20.0f, y, 2.0f);
  EXPECT_EQ(ray_conflict_ratio(behind, target, pose_at(0.0), 0.0, p), 1.0);
  // Rays shorter than the minimum range, or none at all: not computed.
  std::vector<Vec3f> near_only{Vec3f(2.0f, 0.0f, 1.5f)};
  EXPECT_EQ(ray_conflict_ratio(near_only, target, pose_at(0.0), 0.0, p), -1.0);
  // The ray budget is a hard cap.
  p.conflict_rays = 4;
  EXPECT_GE(ray_conflict_ratio(wall_scan, target, pose_at(5.0), 0.0, p), 0.0);
}

TEST(OdometryRobustness, GivenPredictionIsUsedAndNonFiniteOneIgnored) {
  static LidarOdometry odom;
  static OdometryScanBuffers buffers;
  OdometryParams p;
  p.voxel_size = 0.5;
  p.max_range = 40.0;
  odom.configure(p);
  std::mt19937_64 rng(3);
  // Frame 0 at the origin, frame 1 turned by 4 deg and 0.6 m forward (a turn's onset: the
  // constant-velocity prediction is the identity, 4 deg off).
  const Mat4d motion = frame_motion(0.6, 0.07);
  std::vector<Vec3f> scan0 = courtyard(rng), scan1;
  const Mat4d inv = se3_inverse(motion);
  for (const Vec3f& q : courtyard(rng)) {
    const Vec3d s = inv.topLeftCorner<3, 3>() * q.cast<double>() + inv.topRightCorner<3, 1>();
    scan1.push_back(s.cast<float>());
  }
  EXPECT_EQ(odom.register_frame(scan0, buffers).status, OdometryStatus::kFirstFrame);
  const Pose3d given(motion);
  const OdometryResult r = odom.register_frame(scan1, buffers, &given);
  ASSERT_EQ(r.status, OdometryStatus::kOk);
  const Mat4d e = se3_inverse(motion) * r.delta.matrix();
  const Vec3d e_t = e.topRightCorner<3, 1>();
  EXPECT_LT(e_t.norm(), 0.05);
  EXPECT_LT(std::abs(yaw_of(e.topLeftCorner<3, 3>())), 0.005);

  Pose3d bad(motion);
  bad(0, 3) = std::nan("");
  const OdometryResult r2 = odom.register_frame(scan1, buffers, &bad);  // falls back to constant velocity
  EXPECT_TRUE(r2.pose.matrix().allFinite());
  EXPECT_NE(r2.status, OdometryStatus::kEmptyScan);
}

}  // namespace
}  // namespace v2xloc
