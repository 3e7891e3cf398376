// The basin climb (registration/basin_climb.hpp): a hypothesis off its basin's bottom climbs to
// it on the proximity grid and on the k-d tree, the work stays within its bound, the subsample
// is even and exact in size, rank_basins orders leaders before followers and drops the same
// bottom found twice, and bad input scores -1 instead of anything else.
#include "v2xloc/algo/registration/basin_climb.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/search/proximity_grid.hpp"

namespace v2xloc {
namespace {

static ProximityGrid g_grid;              // ~MBs of bitmap: static, not the stack
static KdTreeStorage<Vec3f, 16384> g_tree;
static ClimbScratch g_climb;

// A street corner with irregular features: two facades (x = 8, y = 6), posts along them at
// uneven spacing, a kiosk. Points 0.25 m apart from 0.6 m to 4 m high.
std::vector<Vec3f> corner_scene() {
  std::vector<Vec3f> pts;
  for (double z = 0.6; z <= 4.0; z += 0.5) {
    for (double t = -20.0; t <= 20.0; t += 0.25) {
      pts.emplace_back(8.0f, static_cast<float>(t), static_cast<float>(z));   // facade along y
      pts.emplace_back(static_cast<float>(t), 6.0f, static_cast<float>(z));   // facade along x
    }
    for (double p : {-13.0, -6.5, -2.0, 4.5, 11.0}) {  // posts, unevenly spaced
      pts.emplace_back(static_cast<float>(p), -3.0f, static_cast<float>(z));
      pts.emplace_back(-4.0f, static_cast<float>(p + 1.5), static_cast<float>(z));
    }
    for (double a = -1.0; a <= 1.0; a += 0.25) {  // a kiosk's corner
      pts.emplace_back(static_cast<float>(-9.0 + a), 1.0f, static_cast<float>(z));
      pts.emplace_back(-10.0f, static_cast<float>(1.0 + a), static_cast<float>(z));
    }
  }
  return pts;
}

// The scene seen from the body pose (x, y, yaw): body = R^T (world - t).
std::vector<Vec3f> scan_from(const std::vector<Vec3f>& world, double x, double y, double yaw) {
  std::vector<Vec3f> body;
  const double c = det::cos(yaw), s = det::sin(yaw);
  for (const Vec3f& p : world) {
    const double dx = p.x() - x, dy = p.y() - y;
    body.emplace_back(static_cast<float>(c * dx + s * dy), static_cast<float>(-s * dx + c * dy), p.z());
  }
  return body;
}

class BasinClimbTest : public ::testing::Test {
 protected:
  void SetUp() override {
    map_ = corner_scene();
    ASSERT_EQ(g_tree.build(map_).status, KdBuildStatus::kOk);
    ProximityGridParams gp;
    gp.cell = 1.0f;
    gp.reach = 1.0f;
    g_grid.build(map_, Vec3d(0.0, 0.0, 2.0), Vec3d(30.0, 30.0, 5.0), gp);
    ASSERT_TRUE(g_grid.ready() && g_grid.valid());
    scan_ = scan_from(map_, kTrueX, kTrueY, kTrueYaw);
  }
  static constexpr double kTrueX = 1.3, kTrueY = -0.7, kTrueYaw = 0.3;
  std::vector<Vec3f> map_;
  std::vector<Vec3f> scan_;
};

TEST_F(BasinClimbTest, ScoresTheTruthHighestAndFarPosesLow) {
  const ClimbTarget target{scan_, &g_grid, nullptr};
  BasinClimbParams p;
  const double truth = climb_score(target, kTrueX, kTrueY, kTrueYaw, p, g_climb);
  EXPECT_DOUBLE_EQ(truth, 1.0);  // every point lies on the map
  EXPECT_LT(climb_score(target, kTrueX + 9.0, kTrueY - 7.0, kTrueYaw, p, g_climb), 0.6);
}

TEST_F(BasinClimbTest, ClimbsFromALatticeOffsetToTheBottomOnGridAndTree) {
  BasinClimbParams p;
  p.points = 256;
  p.rounds = 6;
  for (int use_grid = 0; use_grid < 2; ++use_grid) {
    const ClimbTarget target{scan_, use_grid ? &g_grid : nullptr, use_grid ? nullptr : &g_tree.tree};
    PoseSearchCandidate h{0.0, kTrueX + 2.6, kTrueY - 2.2, kTrueYaw};
    const double before = climb_score(target, h.x, h.y, h.yaw, p, g_climb);
    ClimbWork work;
    climb_pose(target, h, p, g_climb, &work);
    SCOPED_TRACE(use_grid ? "grid" : "tree");
    EXPECT_GT(h.score, before);
    EXPECT_LT(std::hypot(h.x - kTrueX, h.y - kTrueY), 1.5);  // was 3.4 m off
    EXPECT_DOUBLE_EQ(h.yaw, kTrueYaw);                        // heading kept
    // Bounded work: the start plus 8 neighbours per round, each p.points lookups at most.
    EXPECT_LE(work.lookups, (1u + 8u * p.rounds) * p.points);
    EXPECT_GT(work.lookups, 0u);
    if (use_grid) {
      EXPECT_EQ(work.node_visits, 0u);
    } else {
      EXPECT_GT(work.node_visits, 0u);
    }
  }
}

TEST_F(BasinClimbTest, ZeroRoundsOnlyRescores) {
  const ClimbTarget target{scan_, &g_grid, nullptr};
  BasinClimbParams p;
  p.rounds = 0;
  PoseSearchCandidate h{0.123, kTrueX + 2.0, kTrueY, kTrueYaw};
  ClimbWork work;
  climb_pose(target, h, p, g_climb, &work);
  EXPECT_DOUBLE_EQ(h.x, kTrueX + 2.0);
  EXPECT_DOUBLE_EQ(h.score, climb_score(target, kTrueX + 2.0, kTrueY, kTrueYaw, p, g_climb));
  EXPECT_EQ(work.lookups, p.points);
}

TEST_F(BasinClimbTest, SubsampleHasExactlyTheRequestedSizeAndSpansTheScan) {
  // 300 above-ground points and 256 wanted: an integer stride (1) would take the first 256, all
  // on one side; the even subsample takes 256 spread over all 300.
  std::vector<Vec3f> scan;
  for (int i = 0; i < 300; ++i) scan.emplace_back(static_cast<float>(i), 0.0f, 1.0f);
  for (int i = 0; i < 50; ++i) scan.emplace_back(0.0f, static_cast<float>(i), 0.0f);  // ground: never scored
  // A map with a point only near the scan's far end (x >= 280): an even subsample sees it.
  std::vector<Vec3f> map;
  for (int i = 280; i < 300; ++i) map.emplace_back(static_cast<float>(i), 0.0f, 1.0f);
  static KdTreeStorage<Vec3f, 64> tree;
  ASSERT_EQ(tree.build(map).status, KdBuildStatus::kOk);
  BasinClimbParams p;
  p.points = 256;
  p.score_distance = 0.1;
  ClimbWork work;
  const double score = climb_score(ClimbTarget{scan, nullptr, &tree.tree}, 0.0, 0.0, 0.0, p, g_climb, &work);
  EXPECT_EQ(work.lookups, 256u);
  EXPECT_GT(score, 15.0 / 256.0);  // ~17 of the 20 points near the far end are in the subsample
  p.points = 1000;                 // more than there are: all 300
  work = {};
  climb_score(ClimbTarget{scan, nullptr, &tree.tree}, 0.0, 0.0, 0.0, p, g_climb, &work);
  EXPECT_EQ(work.lookups, 300u);
}

TEST_F(BasinClimbTest, BadInputScoresMinusOne) {
  BasinClimbParams p;
  EXPECT_EQ(climb_score(ClimbTarget{scan_, nullptr, nullptr}, 0.0, 0.0, 0.0, p, g_climb), -1.0);  // no map
  EXPECT_EQ(climb_score(ClimbTarget{{}, &g_grid, nullptr}, 0.0, 0.0, 0.0, p, g_climb), -1.0);     // no scan
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<Vec3f> bad{{nan, 0.0f, 1.0f}, {1.0f, 1.0f, nan}, {2.0f, 2.0f, 0.0f}};
  // NaN height and ground: nothing to score; a NaN coordinate scores as a miss.
  EXPECT_EQ(climb_score(ClimbTarget{std::span<const Vec3f>(bad).subspan(1), &g_grid, nullptr}, 0.0, 0.0, 0.0, p, g_climb), -1.0);
  EXPECT_EQ(climb_score(ClimbTarget{bad, &g_grid, nullptr}, 0.0, 0.0, 0.0, p, g_climb), 0.0);
  PoseSearchCandidate h{0.5, 1.0, 1.0, 0.0};
  climb_pose(ClimbTarget{scan_, nullptr, nullptr}, h, p, g_climb);
  EXPECT_EQ(h.score, -1.0);
  EXPECT_EQ(h.x, 1.0);  // not moved
}

TEST(RankBasins, LeadersFirstFollowersAfterSameBottomDropped) {
  PoseSearchCandidate h[7] = {
      {0.50, 0.0, 0.0, 0.0},    // follower of the 0.70 leader (3 m away)
      {0.70, 3.0, 0.0, 0.0},    // leader
      {0.69, 4.0, 0.0, 0.0},    // same bottom as the leader (1 m): dropped
      {0.60, 20.0, 0.0, 0.0},   // leader, another basin
      {0.55, 3.0, 0.0, 3.0},    // same place, other heading: a leader
      {-1.0, 0.0, 0.0, 0.0},    // empty
      {0.40, 21.0, 2.0, 0.0},   // follower of the 0.60 leader
  };
  rank_basins(h, 4.5, 0.17, 1.5);
  const double want[7][2] = {{0.70, 3.0}, {0.60, 20.0}, {0.55, 3.0}, {0.50, 0.0}, {0.40, 21.0}, {-1.0, 0.0}, {-1.0, 0.0}};
  for (int i = 0; i < 7; ++i) {
    SCOPED_TRACE(i);
    EXPECT_DOUBLE_EQ(h[i].score, want[i][0]);
    EXPECT_DOUBLE_EQ(h[i].x, want[i][1]);
  }
  EXPECT_DOUBLE_EQ(h[2].yaw, 3.0);
}

TEST(RankBasins, EmptyAndAllEmptyLists) {
  rank_basins(std::span<PoseSearchCandidate>(), 4.5, 0.17, 1.5);
  PoseSearchCandidate h[3];
  rank_basins(h, 4.5, 0.17, 1.5);
  for (const PoseSearchCandidate& c : h) EXPECT_EQ(c.score, -1.0);
}

}  // namespace
}  // namespace v2xloc
