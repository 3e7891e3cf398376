#include "v2xloc/algo/localization/startup_search.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <span>
#include <vector>

#include "corner_map.hpp"
#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/period_work.hpp"

namespace v2xloc {
namespace {

// Configured as the Localizer configures it.
void configure(StartupSearch& search, const LocalizerParams& params) {
  search.configure(params.startup, params.tracking.icp, params.filter.ekf.gates.gnss_sigma_inflation);
}

// A start-up frame of a scan against a map, with a GNSS fix of sigma 3 m.
StartupFrame startup_frame(std::uint32_t index, std::span<const Vec3f> scan, std::span<std::uint32_t> hints,
                           const IcpTarget& map, const Vec3d& fix) {
  StartupFrame f;
  f.frame = index;
  f.t = 0.1 * index;
  f.scan = scan;
  f.search_scan = scan;
  f.tracking_scan = scan;
  f.map = map;
  f.gnss.valid = true;
  f.gnss.enu = fix;
  f.gnss.sigma = 3.0;
  f.filter_needs_start = true;
  f.icp_hints = hints;
  return f;
}

// A period with room to start a search and little more: the search and its final ICP run in
// small slices.
PeriodWork room_to_start_a_search(const PeriodWorkParams& params) {
  PeriodWork work;
  work.configure(params);
  work.add(params.budget - params.search_start - 1e5);
  return work;
}

// The corner map; the scan is a part of it (body = world).
struct CornerScene {
  testing::CornerMap map;
  std::vector<Vec3f> scan;
  std::vector<std::uint32_t> hints;
  std::unique_ptr<PoseSearchScratch> scratch = std::make_unique<PoseSearchScratch>();

  CornerScene() {
    scan.assign(map.points.begin(), map.points.begin() + 900);
    hints.resize(scan.size());
  }
  StartupFrame frame(std::uint32_t index, const Vec3d& fix) { return startup_frame(index, scan, hints, map.target(), fix); }
};

// The map's point spacing is measured, not assumed: the corner map's walls are sampled 0.5 m apart
// (their shared edges hold duplicates, a few percent of the samples: the median ignores them), and
// the same walls sampled every 1 m measure twice that.
TEST(StartupSearch, MapPointSpacingIsTheMedianNearestNeighbourDistance) {
  const testing::CornerMap corner;
  std::uint64_t work = 0;
  EXPECT_NEAR(map_point_spacing(corner.target(), 64, work), 0.5, 1e-6);
  EXPECT_GT(work, 64u);

  std::vector<Vec3f> sparse;
  for (const Vec3f& p : corner.points) {
    if (std::fmod(p.x(), 1.0f) == 0.0f && std::fmod(p.y(), 1.0f) == 0.0f && std::fmod(p.z(), 1.0f) == 0.0f) {
      sparse.push_back(p);
    }
  }
  auto tree = std::make_unique<KdTreeStorage<Vec3f, 4096>>();
  tree->build(sparse);
  const IcpTarget target{sparse, {}, &tree->tree, nullptr, nullptr};
  EXPECT_NEAR(map_point_spacing(target, 64, work), 1.0, 1e-6);

  const IcpTarget empty{};
  EXPECT_EQ(map_point_spacing(empty, 64, work), 0.0);
}

// The ray-conflict radius follows a sparse map's spacing and never drops below the configured one.
TEST(StartupSearch, ConflictRadiusGrowsWithTheMapSpacing) {
  EXPECT_DOUBLE_EQ(conflict_radius_for(0.25, 0.2, 0.45), 0.25);   // a dense map: the configured radius
  EXPECT_DOUBLE_EQ(conflict_radius_for(0.25, 0.8, 0.45), 0.36);   // a sparse one: 0.45 x its spacing
  EXPECT_DOUBLE_EQ(conflict_radius_for(0.25, 0.8, 0.0), 0.25);    // rule off
}

// A canyon fix can be further off than the region's floor: a search that leaves nothing standing
// makes the next one look wider (up to startup.max_region), and a new track starts at the floor.
TEST(StartupSearch, RegionWidensAfterASearchFindsNothing) {
  CornerScene scene;
  LocalizerParams params;
  auto search = std::make_unique<StartupSearch>();
  configure(*search, params);
  LocalizerCounters counters;
  const Vec3d fix(300.0, 300.0, 0.0);  // no map anywhere near it: nothing can be found
  std::vector<double> regions;
  for (std::uint32_t frame = 0; frame < 40 && regions.size() < 3; ++frame) {
    search->on_frame(true, Pose3d::Identity(), GnssFix{});
    const StartupOutcome out = search->step(scene.frame(frame, fix), *scene.scratch, counters);
    if (!out.report.searched) continue;
    EXPECT_EQ(out.status, StartupStatus::kRejected);
    regions.push_back(out.report.region);
  }
  ASSERT_EQ(regions.size(), 3u);
  EXPECT_DOUBLE_EQ(regions[0], params.startup.min_region);
  EXPECT_DOUBLE_EQ(regions[1], params.startup.min_region * params.startup.region_growth);
  EXPECT_DOUBLE_EQ(regions[2], params.startup.max_region) << "capped";
  EXPECT_EQ(counters.global_accepted, 0u);

  search->on_track_lost();  // a new track: back to the floor
  for (std::uint32_t frame = 40; frame < 80; ++frame) {
    search->on_frame(true, Pose3d::Identity(), GnssFix{});
    const StartupOutcome out = search->step(scene.frame(frame, fix), *scene.scratch, counters);
    if (!out.report.searched) continue;
    EXPECT_DOUBLE_EQ(out.report.region, params.startup.min_region);
    break;
  }
}

// The localizer takes no map clouds while the first acquisition is pending (its searches' first
// slices score every hypothesis): that window opens with the first search, however late a map
// arrives after power-up, and ends startup.first_frames later or with the filter's start.
TEST(StartupSearch, FirstAcquisitionWindowOpensWithTheFirstSearch) {
  CornerScene scene;
  LocalizerParams params;
  auto search = std::make_unique<StartupSearch>();
  configure(*search, params);
  EXPECT_TRUE(search->first_acquisition_pending(0));
  EXPECT_TRUE(search->first_acquisition_pending(500)) << "no search yet: no map or no fix so far";
  LocalizerCounters counters;
  constexpr std::uint32_t kFirstMapFrame = 22;  // e.g. the roadside unit comes into V2X range
  search->on_frame(true, Pose3d::Identity(), GnssFix{});
  StartupFrame f = scene.frame(kFirstMapFrame, Vec3d(7.0, 3.0, 0.0));
  search->step(f, *scene.scratch, counters);
  ASSERT_EQ(counters.global_searches, 1u);
  EXPECT_TRUE(search->first_acquisition_pending(kFirstMapFrame + params.startup.first_frames - 1));
  EXPECT_FALSE(search->first_acquisition_pending(kFirstMapFrame + params.startup.first_frames));

  params.startup.first_frames = 0;  // no power-up window once a search ran
  configure(*search, params);
  search->on_frame(true, Pose3d::Identity(), GnssFix{});
  LocalizerCounters again;
  search->step(scene.frame(0, Vec3d(7.0, 3.0, 0.0)), *scene.scratch, again);
  ASSERT_EQ(again.global_searches, 1u);
  EXPECT_FALSE(search->first_acquisition_pending(0));
}

// A finished search's final ICP (up to tracking.icp.max_work) keeps to the period budget like the search:
// with little room left it runs over several periods, and its result is bit-identical to the
// same ICP in one piece (no period budget).
TEST(StartupSearch, FinalIcpRunsInSlicesWithTheSameResult) {
  CornerScene scene;
  for (Vec3f& p : scene.scan) p -= Vec3f(5.0f, 5.0f, 0.0f);  // the body 5 m out from both walls
  LocalizerParams params;
  params.startup.first_work_per_period = 0;  // no power-up exception: every period on the budget
  params.startup.work_per_period = 0;        // the search in one piece: it spends the period ...
  params.startup.min_work_per_period = 200;  // ... and the final ICP's slices in a full period are a few points
  const Vec3d fix(7.0, 3.0, 0.0);
  struct Run {
    StartupOutcome outcome;
    std::uint32_t searched_frame = 0, outcome_frame = 0;
    LocalizerCounters counters;
  };
  const auto run = [&](bool budget) {
    Run r;
    auto search = std::make_unique<StartupSearch>();
    configure(*search, params);
    bool searched = false;
    for (std::uint32_t frame = 0; frame < 60; ++frame) {
      search->on_frame(true, Pose3d::Identity(), GnssFix{});
      PeriodWork work = room_to_start_a_search(params.work);
      StartupFrame f = scene.frame(frame, fix);
      if (budget) f.work = &work;
      const StartupOutcome out = search->step(f, *scene.scratch, r.counters);
      if (out.report.searched && !searched) {
        searched = true;
        r.searched_frame = frame;
      }
      if (out.status == StartupStatus::kRejected || out.status == StartupStatus::kStartFilter) {
        r.outcome = out;
        r.outcome_frame = frame;
        return r;
      }
    }
    return r;
  };
  const Run whole = run(false);
  const Run sliced = run(true);
  ASSERT_TRUE(whole.outcome.registration.ok());
  EXPECT_EQ(whole.counters.global_final_icp_paused, 0u);
  EXPECT_EQ(whole.outcome_frame, whole.searched_frame) << "in one piece: in the period the search finished";
  EXPECT_GT(sliced.counters.global_final_icp_paused, 0u);
  EXPECT_GT(sliced.outcome_frame, sliced.searched_frame) << "the final ICP went on in later periods";
  // The odometry stands still here: the carried result is the ICP's own, bit for bit.
  EXPECT_EQ(sliced.outcome.status, whole.outcome.status);
  EXPECT_EQ(sliced.outcome.registration.status, whole.outcome.registration.status);
  EXPECT_TRUE(sliced.outcome.registration.transform == whole.outcome.registration.transform);
  EXPECT_EQ(sliced.outcome.registration.fitness, whole.outcome.registration.fitness);
  EXPECT_EQ(sliced.outcome.registration.inlier_rmse, whole.outcome.registration.inlier_rmse);
  EXPECT_EQ(sliced.outcome.registration.iterations, whole.outcome.registration.iterations);
}

// A candidate whose final ICP refined an earlier frame's scan (the period ran out of room) is
// confirmed on this frame's, another view: its confirming search starts in the candidate's own
// period (here it also finishes there and starts the filter). A final ICP on this frame's own
// scan leaves the confirmation to a later frame.
TEST(StartupSearch, ConfirmingSearchStartsInTheCandidatesPeriodOnANewScan) {
  CornerScene scene;
  for (Vec3f& p : scene.scan) p -= Vec3f(5.0f, 5.0f, 0.0f);  // the body 5 m out from both walls
  LocalizerParams params;
  params.startup.first_work_per_period = 0;
  params.startup.work_per_period = 0;        // the search in one piece, the final ICP in slices
  params.startup.min_work_per_period = 200;
  params.startup.retry_frames = 1;           // a search may start every frame
  struct Run {
    std::uint32_t outcome_frame = 0, start_frame = 0;
    std::uint64_t searches_at_outcome = 0;
    StartupStatus first_outcome = StartupStatus::kNotDue;
    std::uint64_t confirmed = 0;
  };
  const auto run = [&](bool budget) {
    Run r;
    auto search = std::make_unique<StartupSearch>();
    configure(*search, params);
    LocalizerCounters counters;
    for (std::uint32_t frame = 0; frame < 80 && r.start_frame == 0; ++frame) {
      search->on_frame(true, Pose3d::Identity(), GnssFix{});
      PeriodWork work = room_to_start_a_search(params.work);
      StartupFrame f = scene.frame(frame, Vec3d(7.0, 3.0, 0.0));
      if (budget) f.work = &work;
      const StartupOutcome out = search->step(f, *scene.scratch, counters);
      if (frame == 0) {
        EXPECT_TRUE(out.report.searched) << "the first search in one piece";
      }
      const bool outcome = out.status == StartupStatus::kRejected || out.status == StartupStatus::kStartFilter;
      if (outcome && r.first_outcome == StartupStatus::kNotDue) {
        r.first_outcome = out.status;
        r.outcome_frame = frame;
        r.searches_at_outcome = counters.global_searches;
      }
      if (out.status == StartupStatus::kStartFilter) r.start_frame = frame;
    }
    r.confirmed = counters.global_confirmed;
    return r;
  };
  const Run sliced = run(true);
  EXPECT_GT(sliced.outcome_frame, 0u) << "the final ICP went on in a later period";
  EXPECT_EQ(sliced.searches_at_outcome, 2u) << "the confirming search started with the candidate";
  EXPECT_EQ(sliced.first_outcome, StartupStatus::kStartFilter);
  EXPECT_EQ(sliced.start_frame, sliced.outcome_frame);
  EXPECT_EQ(sliced.confirmed, 1u);
  const Run whole = run(false);
  EXPECT_EQ(whole.outcome_frame, 0u) << "the final ICP on the search's own frame";
  EXPECT_EQ(whole.first_outcome, StartupStatus::kRejected) << "a candidate, to be confirmed";
  EXPECT_EQ(whole.searches_at_outcome, 1u) << "its confirmation waits for the next frame's scan";
  EXPECT_GT(whole.start_frame, whole.outcome_frame);
  EXPECT_EQ(whole.confirmed, 1u);
}

// A confirming search re-decides its candidate's finalists; when the odometry says the pose it
// finds is not the candidate's (here the odometry jumps 0.25 m while the scan stays put: more than a
// 0.1 m confirmation allows, less than the fine ICP pulls back), neither is
// trusted: the new candidate is not output, and the next search is exhaustive (the same
// finalists re-decided again would only repeat themselves), which confirms it.
TEST(StartupSearch, ContradictedCandidateIsNotOutputAndTheNextSearchIsExhaustive) {
  CornerScene scene;
  for (Vec3f& p : scene.scan) p -= Vec3f(5.0f, 5.0f, 0.0f);  // the body 5 m out from both walls
  LocalizerParams params;
  params.startup.confirm_distance = 0.1;
  auto search = std::make_unique<StartupSearch>();
  configure(*search, params);
  LocalizerCounters counters;
  struct Finished {
    StartupStatus status;
    std::uint64_t work;
    bool output;
  };
  std::vector<Finished> searches;
  Pose3d odom = Pose3d::Identity();
  std::uint64_t work_before = 0;
  for (std::uint32_t frame = 0; frame < 80 && searches.size() < 3; ++frame) {
    if (searches.size() == 1) odom.matrix()(0, 3) = 0.25;  // after the first candidate: the jump
    search->on_frame(true, odom, GnssFix{});
    StartupFrame f = scene.frame(frame, Vec3d(7.0, 3.0, 0.0));
    f.course_known = true;  // the scan's heading: a candidate that agrees is output
    f.course = 0.0;
    f.odom_T_body = odom;
    const StartupOutcome out = search->step(f, *scene.scratch, counters);
    if (out.status != StartupStatus::kRejected && out.status != StartupStatus::kStartFilter) continue;
    Pose3d shown;
    searches.push_back({out.status, counters.global_search_work - work_before, search->candidate_pose(frame, odom, shown)});
    work_before = counters.global_search_work;
  }
  ASSERT_EQ(searches.size(), 3u);
  EXPECT_EQ(searches[0].status, StartupStatus::kRejected) << "a candidate, to be confirmed";
  EXPECT_TRUE(searches[0].output) << "its heading agrees with the course: output";
  EXPECT_EQ(searches[1].status, StartupStatus::kRejected);
  EXPECT_EQ(counters.global_inconsistent, 1u) << "the confirming search disagreed through the odometry";
  EXPECT_FALSE(searches[1].output) << "a contradicted candidate is not output";
  EXPECT_EQ(searches[2].status, StartupStatus::kStartFilter) << "the exhaustive search confirms it";
  EXPECT_LT(searches[1].work, searches[0].work) << "the confirming search re-decides finalists only";
  EXPECT_EQ(searches[2].work, searches[0].work) << "exhaustive, as the first (same scan, map and fix)";
  EXPECT_EQ(counters.global_confirmed, 1u);
}

// Two identical corners 30 m apart along x: a scan of one fits both equally, and neither's rays
// cross the other's walls, so a search over both ends ambiguous.
struct TwinCornerScene {
  static constexpr float kShift = 30.0f;
  std::vector<Vec3f> points;
  std::unique_ptr<KdTreeStorage<Vec3f, 8192>> tree = std::make_unique<KdTreeStorage<Vec3f, 8192>>();
  std::vector<Vec3f> normals;
  std::vector<Vec3f> scan;
  std::vector<std::uint32_t> hints;
  std::unique_ptr<PoseSearchScratch> scratch = std::make_unique<PoseSearchScratch>();

  TwinCornerScene() {
    const testing::CornerMap corner;
    points = corner.points;
    for (const Vec3f& p : corner.points) points.push_back(p + Vec3f(kShift, 0.0f, 0.0f));
    tree->build(points);
    normals.resize(points.size());
    NormalParams np;
    np.radius = 1.2f;
    estimate_normals(tree->tree, np, normals);
    scan.assign(corner.points.begin(), corner.points.begin() + 900);
    for (Vec3f& p : scan) p -= Vec3f(5.0f, 5.0f, 0.0f);  // the body 5 m out from both walls
    hints.resize(scan.size());
  }
  StartupFrame frame(std::uint32_t index) {
    const Vec3d halfway(0.5 * kShift + 5.0, 5.0, 0.0);  // the fix between the two
    return startup_frame(index, scan, hints, IcpTarget{points, normals, &tree->tree, nullptr, nullptr}, halfway);
  }
};

// Before a candidate, the output is the running search's best pose so far. A search that ends
// ambiguous (two poses fit alike, neither track nor rays decide) refutes neither: its best pose
// stays the output while the next search starts, until that one has its own, instead of the GNSS
// fix metres off. A search that refuses its answer on its own merits (here: below min_fitness)
// refutes that pose: nothing is held.
TEST(StartupSearch, AmbiguousSearchLeavesItsBestPoseOutputUntilTheNextSearchHasOne) {
  LocalizerParams params;
  params.startup.first_frames = 0;          // no power-up scoring slice: poses come from refinements
  params.startup.work_per_period = 100000;  // the search over several periods (a best pose so far)
  params.startup.min_work_per_period = 20000;
  params.startup.search.refine_points = 256;  // both profiles alike
  struct Frame {
    bool searched = false;
    StartupStatus status = StartupStatus::kNotDue;
    bool shown = false;
    Pose3d pose = Pose3d::Identity();
  };
  const auto run = [](const LocalizerParams& p, auto&& scene_frame, PoseSearchScratch& scratch) {
    auto search = std::make_unique<StartupSearch>();
    configure(*search, p);
    LocalizerCounters counters;
    std::vector<Frame> frames;
    for (std::uint32_t frame = 0; frame < 120; ++frame) {
      search->on_frame(true, Pose3d::Identity(), GnssFix{});
      const StartupOutcome out = search->step(scene_frame(frame), scratch, counters);
      Frame r;
      r.searched = out.report.searched;
      r.status = out.status;
      r.shown = search->candidate_pose(frame, Pose3d::Identity(), r.pose);
      frames.push_back(r);
      if (counters.global_searches == 3) break;
    }
    return frames;
  };
  TwinCornerScene twins;
  const std::vector<Frame> ambiguous = run(params, [&](std::uint32_t i) { return twins.frame(i); }, *twins.scratch);
  std::size_t end = 0;
  while (end < ambiguous.size() && ambiguous[end].status != StartupStatus::kRejected) ++end;
  ASSERT_LT(end + 1, ambiguous.size()) << "the first search ended";
  ASSERT_GT(end, 0u);
  ASSERT_TRUE(ambiguous[end - 1].shown) << "its best pose so far was output while it ran";
  EXPECT_TRUE(ambiguous[end].searched);
  const Mat4d best_so_far = ambiguous[end - 1].pose.matrix();
  std::size_t held = 0;  // the odometry stands still: held means the same pose, bit for bit
  while (end + held < ambiguous.size() && ambiguous[end + held].shown &&
         ambiguous[end + held].pose.matrix() == best_so_far) {
    ++held;
  }
  EXPECT_GE(held, 2u) << "held at the search's end and while the next one starts";
  EXPECT_LE(held, params.startup.confirm_window + 1);
  ASSERT_LT(end + held, ambiguous.size());
  EXPECT_TRUE(ambiguous[end + held].shown) << "the next search's own best pose takes over";
  const double apart = (ambiguous[end + held].pose.translation() - ambiguous[end].pose.translation()).norm();
  EXPECT_NEAR(apart, TwinCornerScene::kShift, 0.1) << "the other of the two look-alikes";

  CornerScene one;  // a single corner: an unambiguous answer ...
  for (Vec3f& p : one.scan) p -= Vec3f(5.0f, 5.0f, 0.0f);
  LocalizerParams strict = params;
  strict.startup.min_fitness = 1.01;  // ... refused on its own fit
  strict.startup.work_per_period = strict.startup.min_work_per_period = 30000;  // over a few periods
  const std::vector<Frame> refused =
      run(strict, [&](std::uint32_t i) { return one.frame(i, Vec3d(7.0, 3.0, 0.0)); }, *one.scratch);
  std::size_t refused_end = 0;
  while (refused_end < refused.size() && refused[refused_end].status != StartupStatus::kRejected) ++refused_end;
  ASSERT_LT(refused_end, refused.size());
  EXPECT_TRUE(refused[refused_end - 1].shown);
  EXPECT_FALSE(refused[refused_end].shown) << "its answer was its best pose so far: refuted, not held";
}

}  // namespace
}  // namespace v2xloc
