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

// A track started in a wrong basin (3 m off the walls) while the search also saw the true one:
// on the next tracked frame the rival, refined, explains the scan far better and takes over.
TEST(RivalBasin, TheTrueBasinTakesOverAWrongStart) {
  Scene scene;
  ASSERT_TRUE(scene.map.normals_ok);
  LocalizerParams params;
  RivalBasin rival;
  configure(rival, params);
  const Pose3d wrong = at(3.0, 3.0);
  rival.note(wrong, 0.20, 0, Pose3d::Identity());
  rival.note(at(0.1, 0.0), 0.18, 0, Pose3d::Identity());
  rival.on_start(wrong, 0, Pose3d::Identity());
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

}  // namespace
}  // namespace v2xloc
