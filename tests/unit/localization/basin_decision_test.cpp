#include "v2xloc/algo/localization/basin_decision.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "corner_map.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"

namespace v2xloc {
namespace {

Mat4d at(double x, double y) {
  Mat4d m = Mat4d::Identity();
  m(0, 3) = x;
  m(1, 3) = y;
  return m;
}

// The tracked pose 3 m off three walls, the candidate at the walls' true pose; the scan is the
// map minus one point, so its size (1,799) divides by no small stride.
struct DecisionScene {
  testing::CornerMap map;
  std::vector<Vec3f> scan;
  std::vector<std::uint32_t> hints;
  LocalizerParams params;
  DecisionScene() {
    scan.assign(map.points.begin(), map.points.end() - 1);
    hints.resize(scan.size());
  }
  BasinDecisionInput input() {
    BasinDecisionInput in;
    in.tracked = at(3.0, 3.0);
    in.candidate = at(0.1, 0.0);
    in.scan = scan;
    in.map = map.target();
    in.icp_hints = hints;
    return in;
  }
  BasinDecision decide(const BasinDecisionInput& in, const BasinDecisionBudget& b) const {
    return decide_basin(in, params.tracking.icp, params.startup.search, b);
  }
};

BasinDecisionBudget priced(double room) {
  BasinDecisionBudget b;
  b.room = room;
  b.pass_price = 1.0;
  b.evaluation_price = 1000.0;
  b.min_points = 100;
  return b;
}

// Whatever the room, a decision that is not forced never prices more than it was given, and a
// subsample takes whole points per pose (the scan's size divides by no stride here).
TEST(BasinDecision, NeverPricesMoreThanTheRoom) {
  DecisionScene s;
  ASSERT_TRUE(s.map.normals_ok);
  const double n = static_cast<double>(s.scan.size());
  int decided = 0, subsampled = 0;
  for (double share = 0.0; share <= 1.2; share += 0.05) {
    const BasinDecisionBudget b = priced(40.0 * n + 2.0 * 1000.0 * n * share);
    const BasinDecision d = s.decide(s.input(), b);
    EXPECT_LE(d.priced(b), b.room) << "room for " << share << " of the scan";
    if (d.state == BasinDecisionState::kDecided) {
      ++decided;
      if (d.stride > 1) ++subsampled;
      EXPECT_GT(d.candidate_fitness, d.tracked_fitness);
    }
  }
  EXPECT_GT(decided, 10);
  EXPECT_GT(subsampled, 5);
}

// No room, or a negative one (a caller's rest after an overrun), runs nothing; a forced decision
// runs the whole ICP and the finest subsample the room holds, at worst min_points a pose.
TEST(BasinDecision, NoRoomWaitsAndAForcedOneDecides) {
  DecisionScene s;
  ASSERT_TRUE(s.map.normals_ok);
  for (const double room : {0.0, -1e8}) {
    const BasinDecision d = s.decide(s.input(), priced(room));
    EXPECT_EQ(d.state, BasinDecisionState::kWaiting) << room;
    EXPECT_EQ(d.queries, 0u) << room;
    EXPECT_EQ(d.evaluated, 0u) << room;
  }
  BasinDecisionBudget b = priced(-1e8);
  b.forced = true;
  const BasinDecision forced = s.decide(s.input(), b);
  ASSERT_EQ(forced.state, BasinDecisionState::kDecided);
  EXPECT_EQ(forced.stride, s.scan.size() / b.min_points);
  EXPECT_GT(forced.candidate_fitness, forced.tracked_fitness);
  b.room = 1e12;  // forced with all the room it could use: the whole scan
  EXPECT_EQ(s.decide(s.input(), b).stride, 1u);
  // Room for the ICP and ~30 points a pose: under the 100-point floor it waits; with no floor
  // (min_points 0) it decides on what fits.
  b.forced = false;
  b.room = 40.0 * static_cast<double>(s.scan.size()) + 2.0 * 1000.0 * 10.0;
  EXPECT_EQ(s.decide(s.input(), b).state, BasinDecisionState::kWaiting);
  b.min_points = 0;
  const BasinDecision sparse = s.decide(s.input(), b);
  ASSERT_EQ(sparse.state, BasinDecisionState::kDecided);
  EXPECT_GT(sparse.stride, s.scan.size() / 100);
  EXPECT_LE(sparse.priced(b), b.room);
}

// A finished ICP whose evaluations wait is not run again; a candidate inside the tracked basin is
// no decision.
TEST(BasinDecision, RefinedCandidatesSkipTheIcpAndTheTrackedBasinIsLost) {
  DecisionScene s;
  ASSERT_TRUE(s.map.normals_ok);
  BasinDecisionInput in = s.input();
  in.refined = true;
  in.candidate = Mat4d::Identity();
  const BasinDecision d = s.decide(in, priced(1e12));
  EXPECT_EQ(d.state, BasinDecisionState::kDecided);
  EXPECT_EQ(d.queries, 0u);
  EXPECT_TRUE(d.refined.isApprox(Mat4d::Identity()));
  in.candidate = at(3.5, 3.0);  // 0.5 m from the tracked pose
  EXPECT_EQ(s.decide(in, priced(1e12)).state, BasinDecisionState::kLost);
}

}  // namespace
}  // namespace v2xloc
