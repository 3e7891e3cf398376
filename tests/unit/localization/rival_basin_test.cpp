#include "v2xloc/algo/localization/rival_basin.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "corner_map.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"

namespace v2xloc {
namespace {

Pose3d at(double x, double y) {
  Pose3d p = Pose3d::Identity();
  p.translation() = Vec3d(x, y, 0.0);
  return p;
}

// Configured as TrackingRegistration configures it.
void configure(RivalBasin& rival, const LocalizerParams& params) {
  rival.configure(params.tracking.rival, params.startup.search, params.tracking.icp);
}

// The alias a start-up search saw beside the basin the filter starts at contests the track when
// its tight fitness reaches contest_ratio of the started basin's; weaker, older or same-basin
// hypotheses do not.
TEST(RivalBasin, ContestsAStartOnlyWithAComparableDistinctHypothesis) {
  LocalizerParams params;
  RivalBasin rival;
  configure(rival, params);
  const Pose3d odom = Pose3d::Identity();
  const double ratio = params.tracking.rival.contest_ratio;

  rival.note(at(0.0, 0.0), 0.20, 5, odom);
  rival.note(at(21.0, 0.0), 0.20 * ratio + 0.01, 5, odom);
  rival.on_start(at(0.0, 0.0), 7, odom);
  EXPECT_TRUE(rival.contested()) << "a 21 m alias with " << ratio << " of the tight fitness";

  rival.reset();
  rival.note(at(0.0, 0.0), 0.20, 5, odom);
  rival.note(at(21.0, 0.0), 0.20 * ratio - 0.01, 5, odom);
  rival.on_start(at(0.0, 0.0), 7, odom);
  EXPECT_FALSE(rival.contested()) << "a clearly weaker hypothesis";

  rival.note(at(0.0, 0.0), 0.20, 5, odom);
  rival.note(at(0.5, 0.0), 0.19, 5, odom);  // the same basin
  rival.on_start(at(0.0, 0.0), 7, odom);
  EXPECT_FALSE(rival.contested()) << "a hypothesis in the started basin";

  rival.note(at(21.0, 0.0), 0.20, 5, odom);
  rival.on_start(at(0.0, 0.0), 5 + params.tracking.rival.max_age_frames + 1, odom);
  EXPECT_FALSE(rival.contested()) << "a hypothesis older than max_age_frames";

  rival.note(at(21.0, 0.0), 0.20, 5, odom);
  rival.on_start(at(0.0, 0.0), 7, odom);
  EXPECT_TRUE(rival.contested()) << "no note in the started basin: the rival is compared with the best noted";
  rival.reset();
  rival.on_start(at(0.0, 0.0), 8, odom);
  EXPECT_FALSE(rival.contested()) << "the notes are gone after a reset";
}

struct Scene {
  testing::CornerMap map;
  std::vector<Vec3f> scan;
  std::vector<std::uint32_t> hints;
  Scene() {
    scan.assign(map.points.begin(), map.points.end());
    hints.resize(scan.size());
  }
  RivalFrame frame(const Pose3d& tracked, std::uint32_t frame_index) {
    RivalFrame f;
    f.tracked = tracked;
    f.scan = scan;
    f.map = map.target();
    f.icp_hints = hints;
    f.frame = frame_index;
    return f;
  }
};

// A start 3 m off the walls (a wrong basin) while the search also saw the true pose: contested.
Pose3d start_wrong(RivalBasin& rival, const LocalizerParams& params) {
  configure(rival, params);
  const Pose3d wrong = at(3.0, 3.0);
  rival.note(wrong, 0.20, 0, Pose3d::Identity());
  rival.note(at(0.1, 0.0), 0.18, 0, Pose3d::Identity());
  rival.on_start(wrong, 0, Pose3d::Identity());
  return wrong;
}

// A track started in a wrong basin (3 m off the walls) while the search also saw the true one:
// on the next tracked frame the rival, refined, explains the scan far better and takes over.
TEST(RivalBasin, TheTrueBasinTakesOverAWrongStart) {
  Scene scene;
  ASSERT_TRUE(scene.map.normals_ok);
  LocalizerParams params;
  RivalBasin rival;
  const Pose3d wrong = start_wrong(rival, params);
  ASSERT_TRUE(rival.contested());
  const RivalOutcome r = rival.check(scene.frame(wrong, 1));
  EXPECT_TRUE(r.checked);
  EXPECT_GT(r.queries, 0u);
  EXPECT_TRUE(r.switch_basin);
  EXPECT_LT(r.candidate.translation().norm(), 0.05) << "refined onto the walls";
  EXPECT_FALSE(rival.contested());
}

// The true track against a rival the scan does not hold: the contest ends in the track's favour
// and its registrations are no longer withheld.
TEST(RivalBasin, ATrueTrackStandsAgainstAWeakRival) {
  Scene scene;
  ASSERT_TRUE(scene.map.normals_ok);
  LocalizerParams params;
  RivalBasin rival;
  configure(rival, params);
  rival.note(at(0.0, 0.0), 0.20, 0, Pose3d::Identity());
  rival.note(at(3.0, 3.0), 0.19, 0, Pose3d::Identity());
  rival.on_start(at(0.0, 0.0), 0, Pose3d::Identity());
  ASSERT_TRUE(rival.contested());
  const RivalOutcome r = rival.check(scene.frame(at(0.0, 0.0), 1));
  EXPECT_TRUE(r.checked);
  EXPECT_FALSE(r.switch_basin);
  EXPECT_FALSE(rival.contested());
  EXPECT_FALSE(rival.check(scene.frame(at(0.0, 0.0), 2)).checked) << "decided: no more checks";
}

// The period's remaining budget prices the check: priced work never exceeds the room it was
// given; a frame without room for one ICP pass waits, an ICP the room ends resumes next frame from
// the carried pose, and after max_deferred_frames frames without a decision one runs regardless.
TEST(RivalBasin, TheCheckStaysWithinThePeriodsRoomAndStillDecides) {
  Scene scene;
  ASSERT_TRUE(scene.map.normals_ok);
  LocalizerParams params;
  params.tracking.rival.decision.min_points = 300;
  RivalBasin rival;
  const Pose3d wrong = start_wrong(rival, params);
  ASSERT_TRUE(rival.contested());
  const double n = static_cast<double>(scene.scan.size());
  const std::uint32_t max_deferred = params.tracking.rival.decision.max_deferred_frames;
  std::uint32_t deferred = 0, frames = 0;
  RivalOutcome decided;
  for (std::uint32_t k = 1; k <= 2 * max_deferred + 2 && rival.contested(); ++k) {
    RivalFrame f = scene.frame(wrong, k);
    BasinDecisionBudget& b = f.budget;
    b.pass_price = 1000.0;
    b.evaluation_price = 1000.0;
    b.room = k == 1 ? 0.5 * n * b.pass_price : 2.5 * n * b.pass_price;  // no pass, then two a frame
    const bool forced = deferred >= max_deferred;
    const RivalOutcome r = rival.check(f);
    ++frames;
    EXPECT_TRUE(r.checked);
    const double priced = static_cast<double>(r.queries) * b.pass_price + static_cast<double>(r.evaluated) * b.evaluation_price;
    if (!forced) {
      EXPECT_LE(priced, b.room) << "frame " << k;
    }
    if (k == 1) {
      EXPECT_EQ(r.queries, 0u) << "no room for a pass: nothing runs";
    }
    if (r.deferred) {
      ++deferred;
      EXPECT_EQ(r.evaluated, 0u);
      EXPECT_TRUE(rival.contested());
      continue;
    }
    deferred = 0;
    decided = r;
  }
  EXPECT_FALSE(rival.contested()) << "decided within " << frames << " frames";
  EXPECT_GE(frames, 3u) << "frame 1 waited, and two passes a frame did not finish the ICP at once";
  EXPECT_TRUE(decided.switch_basin);
  EXPECT_GT(decided.stride, 1u) << "the room held a subsample, not the whole scan";
  EXPECT_LT(decided.candidate.translation().norm(), 0.05) << "refined onto the walls across frames";
}

// Room for the ICP and for a third of the scan per pose: the two poses are judged on an even
// subsample and the true basin still wins.
TEST(RivalBasin, AnEvenSubsampleDecidesWhenTheWholeScanDoesNotFit) {
  Scene scene;
  ASSERT_TRUE(scene.map.normals_ok);
  LocalizerParams params;
  params.tracking.rival.decision.min_points = 300;
  RivalBasin rival;
  const Pose3d wrong = start_wrong(rival, params);
  RivalFrame f = scene.frame(wrong, 1);
  const double n = static_cast<double>(scene.scan.size());
  BasinDecisionBudget& b = f.budget;
  b.pass_price = 1.0;
  b.evaluation_price = 1000.0;
  b.room = n * (params.tracking.icp.criteria.max_iterations + 1.0) + 2.0 * b.evaluation_price * n / 3.0;
  const RivalOutcome r = rival.check(f);
  EXPECT_FALSE(r.deferred);
  EXPECT_GE(r.stride, 2u);
  EXPECT_LE(r.stride, 3u);
  EXPECT_LE(static_cast<double>(r.queries) * b.pass_price + static_cast<double>(r.evaluated) * b.evaluation_price, b.room);
  EXPECT_TRUE(r.switch_basin);
  EXPECT_FALSE(rival.contested());
}

}  // namespace
}  // namespace v2xloc
