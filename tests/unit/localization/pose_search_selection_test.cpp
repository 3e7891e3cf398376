// The pose search's selection on a sparse map (EMBEDDED start-up): a refined pose outside the
// searched region is no candidate (max_offset), a pose whose rays cross the map does not set
// the fitness margin the others are judged against (clear_margin), and the best-scored hypothesis
// output while the search runs (provisional_scored) is withdrawn once its refinement refutes it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "courtyard_search.hpp"
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"
#include "v2xloc/algo/search/kdtree.hpp"

namespace v2xloc {
namespace {

PoseSearchScratch& scratch() {
  static PoseSearchScratch s;
  return s;
}

// Uniform samples of an axis-aligned vertical wall from (x0, y0) to (x1, y1), 4 m high.
void wall(std::vector<Vec3f>& pts, std::mt19937_64& rng, float x0, float y0, float x1, float y1, int n) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < n; ++i) {
    const float t = u(rng);
    pts.emplace_back(x0 + t * (x1 - x0), y0 + t * (y1 - y0), 4.0f * u(rng));
  }
}

// A courtyard (walls x = cx +- 10, y = +-6) with its ground; `with` selects the walls:
// bit 0 x-, bit 1 x+, bit 2 y-, bit 3 y+.
void courtyard(std::vector<Vec3f>& pts, std::mt19937_64& rng, float cx, unsigned with) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  if (with & 1u) wall(pts, rng, cx - 10.0f, -6.0f, cx - 10.0f, 6.0f, 800);
  if (with & 2u) wall(pts, rng, cx + 10.0f, -6.0f, cx + 10.0f, 6.0f, 800);
  if (with & 4u) wall(pts, rng, cx - 10.0f, -6.0f, cx + 10.0f, -6.0f, 1500);
  if (with & 8u) wall(pts, rng, cx - 10.0f, 6.0f, cx + 10.0f, 6.0f, 1500);
  for (int i = 0; i < 1500; ++i) pts.emplace_back(cx - 10.0f + 20.0f * u(rng), -6.0f + 12.0f * u(rng), 0.0f);
}

struct Target {
  std::vector<Vec3f> points;
  std::vector<Vec3f> normals;
  KdTreeStorage<Vec3f, 16384> tree;
  IcpTarget icp{};
};

void build(Target& t) {
  ASSERT_EQ(t.tree.build(t.points).status, KdBuildStatus::kOk);
  t.normals.assign(t.points.size(), Vec3f::Zero());
  NormalParams np;
  np.radius = 0.8f;
  estimate_normals(t.tree.tree, np, std::span<Vec3f>(t.normals));
  t.icp = IcpTarget{t.points, t.normals, &t.tree.tree};
}

Mat4d pose_at(double x, double y, double yaw) {
  Mat4d p = Mat4d::Identity();
  p.topLeftCorner<3, 3>() = rot_z(yaw);
  p(0, 3) = x;
  p(1, 3) = y;
  return p;
}

// Every 4th point of `world`, in the body frame of `pose`.
std::vector<Vec3f> scan_of(const std::vector<Vec3f>& world, const Mat4d& pose) {
  const Mat4d inv = se3_inverse(pose);
  std::vector<Vec3f> scan;
  for (std::size_t i = 0; i < world.size(); i += 4) {
    scan.push_back((inv.topLeftCorner<3, 3>() * world[i].cast<double>() + inv.topRightCorner<3, 1>()).cast<float>());
  }
  return scan;
}

double horizontal(const Mat4d& a, const Vec3d& b) { return std::hypot(a(0, 3) - b.x(), a(1, 3) - b.y()); }

// Two courtyards 40 m apart in the map: the west one whole, with a partition 4.5 m east of its
// centre, the east one with only its east and south walls and the western half of its north wall.
// The world the scan sees is the east one whole (the vehicle stands in it).
std::vector<Vec3f> two_courtyards(Target& map, std::mt19937_64& rng) {
  courtyard(map.points, rng, 0.0f, 15u);
  wall(map.points, rng, 5.0f, -4.0f, 5.0f, 4.0f, 600);  // the partition
  courtyard(map.points, rng, 40.0f, 2u | 4u);
  wall(map.points, rng, 30.0f, 6.0f, 40.0f, 6.0f, 750);  // the north wall's western half
  build(map);
  std::vector<Vec3f> world;
  courtyard(world, rng, 40.0f, 15u);
  return world;
}

// The courtyard matches itself turned by 180 degrees: both basins lie in the 4 m disc. With the
// region cut to 1.5 m around the centre the mirror's refined pose is outside it: it is no
// candidate (no runner-up), and the truth inside still wins.
TEST(PoseSearchSelection, RefinedPoseOutsideTheRegionIsNoCandidate) {
  std::mt19937_64 rng(7);
  static Target map;
  courtyard(map.points, rng, 0.0f, 15u);
  build(map);
  std::vector<Vec3f> world;
  courtyard(world, rng, 0.0f, 15u);
  const Mat4d truth = pose_at(0.5, 0.0, 0.3);
  const std::vector<Vec3f> scan = scan_of(world, truth);
  const Vec3d centre(1.0, 0.5, 0.0);  // truth 0.7 m away, the mirror (-0.5, 0) 1.6 m
  PoseSearchParams sp = testing::courtyard_search_params();

  static PoseSearch open;
  const PoseSearchResult& all = open.run(scan, map.icp, centre, sp, scratch());
  ASSERT_TRUE(all.best.ok());
  ASSERT_TRUE(all.runner_up.ok()) << "both basins are refined and measured without the cut";
  const double farther = std::max(horizontal(all.best.transform, centre), horizontal(all.runner_up.transform, centre));
  EXPECT_GT(farther, 1.5) << "one of them is the mirror, outside the cut";

  sp.max_offset = 1.5;
  static PoseSearch cut;
  const PoseSearchResult& r = cut.run(scan, map.icp, centre, sp, scratch());
  ASSERT_TRUE(r.best.ok());
  EXPECT_LT(horizontal(r.best.transform, truth.topRightCorner<3, 1>()), 0.05);
  EXPECT_EQ(r.runner_up_tight_fitness, 0.0) << "the mirror outside the region is not a runner-up";
  Mat4d finalists[kPoseSearchRefine];
  const std::uint32_t n = cut.finalists(finalists);
  ASSERT_GE(n, 1u);
  for (std::uint32_t i = 0; i < n; ++i) EXPECT_LE(horizontal(finalists[i], centre), 1.5);

  sp.max_offset = 0.2;  // nothing refined lies this close: no solution rather than one outside
  static PoseSearch none;
  EXPECT_FALSE(none.run(scan, map.icp, centre, sp, scratch()).best.ok());
}

// Two courtyards 40 m apart. The vehicle stands in the east one, which the map holds only in part
// (its west wall and half its north wall missing: fewer of the scan's points find the map); the
// west one is whole and has a partition 4.5 m east of where the vehicle would stand, so the same
// scan placed there fits the map better but looks through the partition. Both poses are re-decided
// (start_from_poses): without clear_margin the wall-crossing pose's fitness sets the margin, the
// truth falls outside it and nothing is chosen; with it the truth wins.
TEST(PoseSearchSelection, WallCrossingPoseDoesNotSetTheFitnessMargin) {
  std::mt19937_64 rng(11);
  static Target map;
  const std::vector<Vec3f> world = two_courtyards(map, rng);
  const Mat4d truth = pose_at(40.5, 0.0, 0.0);
  const Mat4d alias = pose_at(0.5, 0.0, 0.0);
  const std::vector<Vec3f> scan = scan_of(world, truth);
  const Mat4d given[2] = {alias, truth};

  PoseSearchParams sp = testing::courtyard_search_params();
  sp.max_conflicts = 0.1;
  sp.sensor_in_body = Vec3d(0.0, 0.0, 1.0);
  const double alias_fit = evaluate_registration(scan, map.icp, alias, sp.fine_icp.max_correspondence_distance).fitness;
  const double truth_fit = evaluate_registration(scan, map.icp, truth, sp.fine_icp.max_correspondence_distance).fitness;
  ASSERT_GT(alias_fit, truth_fit + kPoseSearchFitnessMargin) << "the scene must put the truth outside the margin";
  ASSERT_GT(ray_conflict_ratio(scan, map.icp, alias, 0.0, sp), sp.max_conflicts);
  ASSERT_LE(ray_conflict_ratio(scan, map.icp, truth, 0.0, sp), sp.max_conflicts);

  sp.clear_margin = false;
  static PoseSearch loose;
  loose.start_from_poses(scan, map.icp, std::span<const Mat4d>(given, 2), 0.0, sp);
  ASSERT_TRUE(loose.step(map.icp, scratch(), ~std::uint64_t{0}));
  EXPECT_FALSE(loose.result().best.ok()) << "the truth is out of the margin the wall-crossing pose set";
  EXPECT_EQ(loose.result().conflict_rejected, 1u);

  sp.clear_margin = true;
  static PoseSearch clear;
  clear.start_from_poses(scan, map.icp, std::span<const Mat4d>(given, 2), 0.0, sp);
  ASSERT_TRUE(clear.step(map.icp, scratch(), ~std::uint64_t{0}));
  const PoseSearchResult& r = clear.result();
  ASSERT_TRUE(r.best.ok());
  EXPECT_LT(horizontal(r.best.transform, truth.topRightCorner<3, 1>()), 0.05);
  EXPECT_GT(r.best_tight_fitness, 0.0);
  EXPECT_EQ(r.conflict_rejected, 1u);
}

// The same two courtyards searched exhaustively from between them. The west one, whole, outscores
// the partial east one where the vehicle stands, so the best-scored hypothesis is an alias there;
// its refined pose looks through the partition. The search outputs the alias while it refines it
// (provisional_scored), then nothing once the ray check refuted it (not the alias while the other
// candidates are refined), until a refined pose is rated; its last output is a refined
// pose in the vehicle's courtyard (the truth or its mirror: the selection decides between them).
TEST(PoseSearchSelection, ALeaderItsRefinementRefutesIsNoLongerOutput) {
  std::mt19937_64 rng(11);
  static Target map;
  const std::vector<Vec3f> world = two_courtyards(map, rng);
  const Vec3d truth(40.5, 0.0, 0.0);
  const std::vector<Vec3f> scan = scan_of(world, pose_at(truth.x(), truth.y(), 0.0));

  PoseSearchParams sp = testing::courtyard_search_params();
  sp.radius = 22.0;
  sp.step = 2.0;
  sp.yaw_steps = 8;
  sp.max_conflicts = 0.1;
  sp.sensor_in_body = Vec3d(0.0, 0.0, 1.0);
  sp.clear_margin = true;
  sp.provisional = true;
  sp.provisional_scored = true;
  static PoseSearch search;
  search.start(scan, map.icp, Vec3d(20.5, 0.0, 0.0), sp);
  std::vector<double> output_x;  // each step's output: its x (NaN: none)
  bool done = false;
  for (int i = 0; i < 100000 && !done; ++i) {
    done = search.step(map.icp, scratch(), 2000);
    Mat4d pose;
    output_x.push_back(search.provisional(pose) ? pose(0, 3) : std::nan(""));
  }
  ASSERT_TRUE(done);
  ASSERT_TRUE(search.result().best.ok());
  EXPECT_LT(horizontal(search.result().best.transform, truth), 1.5) << "the vehicle's courtyard";
  const auto in_west = [](double x) { return std::isfinite(x) && x < 20.0; };
  const auto first_west = std::find_if(output_x.begin(), output_x.end(), in_west);
  ASSERT_NE(first_west, output_x.end()) << "the scored leader (the alias) is output while it is refined";
  const auto after = std::find_if_not(first_west, output_x.end(), in_west);
  ASSERT_NE(after, output_x.end());
  EXPECT_TRUE(std::isnan(*after)) << "refuted, the alias gives way to no output (the GNSS fix's) "
                                     "until a refined pose is rated";
  EXPECT_EQ(std::find_if(after, output_x.end(), in_west), output_x.end()) << "nor is it output again";
  ASSERT_TRUE(std::isfinite(output_x.back()));
  EXPECT_NEAR(output_x.back(), truth.x(), 1.5);
}


// Two poses that fit about as well are told apart by the map's negative evidence only when one's
// rays cross mapped surfaces clearly more often: a start-up search's alias 21 m along the street
// (9 of 128 rays, 0.070) against the true pose (2 of 128, 0.016), EMBEDDED.
TEST(PoseSearchSelection, ClearlyFewerRayConflictsDecideAnAmbiguity) {
  const double ratio = 2.0, margin = 0.04;
  EXPECT_EQ(clearly_fewer_conflicts(0.016, 0.070, ratio, margin), 0);
  EXPECT_EQ(clearly_fewer_conflicts(0.109, 0.031, ratio, margin), 1);
  EXPECT_EQ(clearly_fewer_conflicts(0.0, 0.047, ratio, margin), 0);  // no conflict at all against 6 rays
  EXPECT_EQ(clearly_fewer_conflicts(0.0, 0.031, ratio, margin), -1);  // 4 rays: within the margin
  EXPECT_EQ(clearly_fewer_conflicts(0.100, 0.180, ratio, margin), -1);  // under 2x: both look through walls
  EXPECT_EQ(clearly_fewer_conflicts(0.050, 0.050, ratio, margin), -1);
  EXPECT_EQ(clearly_fewer_conflicts(-1.0, 0.2, ratio, margin), -1);  // rays not checked
  EXPECT_EQ(clearly_fewer_conflicts(0.016, -1.0, ratio, margin), -1);
  EXPECT_EQ(clearly_fewer_conflicts(std::nan(""), 0.2, ratio, margin), -1);
}

// The best pose so far, which a running search outputs: a near-tie in tight fitness goes to the
// pose whose rays clearly cross fewer mapped surfaces (an EMBEDDED search on a 12,288-point map
// output an alias 27 m along the street: tight 0.209 against the truth's 0.189, conflicts 0.117
// against 0.023).
TEST(PoseSearchSelection, NearTieForTheBestSoFarGoesToFewerRayConflicts) {
  const double ambiguity = 0.85, ratio = 2.0, margin = 0.04;
  const RatedPose truth{0.1885, 0.023}, alias{0.2094, 0.117};
  EXPECT_FALSE(replaces_best_so_far(alias, truth, ambiguity, ratio, margin));
  EXPECT_TRUE(replaces_best_so_far(truth, alias, ambiguity, ratio, margin));
  EXPECT_TRUE(replaces_best_so_far(alias, truth, 0.0, ratio, margin));  // rule off: the higher fitness
  // Clearly apart in fitness: the higher wins whatever its rays.
  EXPECT_TRUE(replaces_best_so_far({0.30, 0.11}, {0.20, 0.01}, ambiguity, ratio, margin));
  EXPECT_FALSE(replaces_best_so_far({0.20, 0.01}, {0.30, 0.11}, ambiguity, ratio, margin));
  // A near-tie the rays cannot decide (too close, or unchecked): the higher fitness.
  EXPECT_TRUE(replaces_best_so_far({0.21, 0.05}, {0.20, 0.04}, ambiguity, ratio, margin));
  EXPECT_FALSE(replaces_best_so_far({0.20, 0.04}, {0.21, 0.05}, ambiguity, ratio, margin));
  EXPECT_TRUE(replaces_best_so_far({0.21, -1.0}, {0.20, 0.0}, ambiguity, ratio, margin));
  EXPECT_FALSE(replaces_best_so_far({0.20, 0.0}, {0.20, 0.0}, ambiguity, ratio, margin));  // equal: the first stays
}
}  // namespace
}  // namespace v2xloc
