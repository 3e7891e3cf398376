// The proximity bitmap against brute force: never a false negative for a query in the box
// (random and adversarial boundary cases), false positives within the documented bound, sliced
// builds bit-identical to one build, growth instead of overflow, counted bad points, and the
// documented work bound.
#include "v2xloc/algo/search/proximity_grid.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include "v2xloc/algo/core/prng.hpp"

namespace v2xloc {
namespace {

static ProximityGrid grid;
static ProximityGrid other;

std::vector<Vec3f> uniform_points(Pcg32& rng, std::size_t n, const Vec3d& lo, const Vec3d& hi) {
  std::vector<Vec3f> pts(n);
  for (Vec3f& p : pts) {
    for (int a = 0; a < 3; ++a) p[a] = static_cast<float>(rng.uniform(lo[a], hi[a]));
  }
  return pts;
}

// The largest per-axis distance from q to its Chebyshev-nearest map point, and whether some
// map point lies within `reach` (exact: float differences and their squares are exact in double
// up to one rounding of the sum).
struct BruteForce {
  bool within_reach = false;
  double chebyshev = std::numeric_limits<double>::infinity();
};

BruteForce brute_force(const std::vector<Vec3f>& map, const Vec3f& q, double reach) {
  BruteForce b;
  for (const Vec3f& p : map) {
    double d2 = 0.0, cheb = 0.0;
    for (int a = 0; a < 3; ++a) {
      const double d = static_cast<double>(q[a]) - static_cast<double>(p[a]);
      d2 += d * d;
      cheb = std::abs(d) > cheb ? std::abs(d) : cheb;
    }
    b.within_reach = b.within_reach || d2 <= reach * reach;
    b.chebyshev = cheb < b.chebyshev ? cheb : b.chebyshev;
  }
  return b;
}

// Random queries in the box: every query with a map point within reach is near, and every near
// query has a map point within (r + 1 + 2^-19) cells on every axis. Returns {hits, misses}.
std::pair<int, int> check_against_brute_force(const ProximityGrid& g, const std::vector<Vec3f>& map,
                                              const Vec3d& center, const Vec3d& half, double reach,
                                              std::uint64_t seed, int queries) {
  Pcg32 rng(seed);
  const double bound = (g.reach_cells() + 1.0 + 1.0 / 524288.0) * g.cell();
  int hits = 0, misses = 0;
  for (const Vec3f& q : uniform_points(rng, static_cast<std::size_t>(queries), center - half, center + half)) {
    const BruteForce b = brute_force(map, q, reach);
    const bool near = g.near(q);
    if (b.within_reach) {
      EXPECT_TRUE(near) << "false negative at " << q.transpose();
    }
    if (near) {
      EXPECT_LE(b.chebyshev, bound) << "false positive beyond the bound at " << q.transpose();
    }
    (near ? hits : misses) += 1;
  }
  return {hits, misses};
}

TEST(ProximityGrid, NoFalseNegativeAndBoundedFalsePositivesAgainstBruteForce) {
  // 120 m along x: rows of 2-4 words, so bits cross word boundaries in the x dilation.
  const Vec3d center(5.25, -3.5, 1.0), half(60.0, 12.0, 4.0);
  Pcg32 rng(11);
  // Map points in the box and in the reach margin around it (they count for queries inside).
  const auto map = uniform_points(rng, 500, center - half - Vec3d(3, 3, 3), center + half + Vec3d(3, 3, 3));
  struct Case {
    float cell, reach;
    std::uint32_t r;
  };
  for (const Case c : {Case{1.0f, 2.0f, 2}, Case{0.7f, 1.5f, 3}, Case{1.0f, 2.5f, 3}, Case{2.0f, 2.0f, 1},
                       Case{0.5f, 0.3f, 1}}) {
    grid.build(map, center, half, {c.cell, c.reach});
    ASSERT_TRUE(grid.ready() && grid.valid());
    EXPECT_EQ(grid.cell(), static_cast<double>(c.cell)) << "fits: no growth";
    EXPECT_EQ(grid.reach_cells(), c.r);
    EXPECT_EQ(grid.points_marked() + grid.points_outside(), map.size());
    const auto [hits, misses] = check_against_brute_force(grid, map, center, half, c.reach, 12, 20000);
    EXPECT_GT(hits, 500) << c.cell << " " << c.reach;
    EXPECT_GT(misses, 500) << c.cell << " " << c.reach;
  }
}

// none_within_reach() is a proof: wherever it says so (queries all over and beyond the grid),
// brute force finds no map point within reach; covers() holds on the whole box B.
TEST(ProximityGrid, NoneWithinReachIsExact) {
  const Vec3d center(-2.0, 7.5, 0.5), half(30.0, 20.0, 5.0);
  Pcg32 rng(21);
  const auto map = uniform_points(rng, 300, center - half, center + half);
  for (const float reach : {1.01f, 2.0f}) {
    grid.build(map, center, half, {0.5f, reach});
    ASSERT_TRUE(grid.ready() && grid.valid());
    EXPECT_EQ(grid.reach(), static_cast<double>(reach));
    int proven = 0;
    const Vec3d margin(4.0, 4.0, 4.0);
    for (const Vec3f& q : uniform_points(rng, 20000, center - half - margin, center + half + margin)) {
      if (!grid.none_within_reach(q)) continue;
      ++proven;
      EXPECT_FALSE(brute_force(map, q, reach).within_reach) << q.transpose();
    }
    EXPECT_GT(proven, 1000) << reach;
    for (const Vec3f& q : uniform_points(rng, 2000, center - half, center + half)) EXPECT_TRUE(grid.covers(q));
  }
  EXPECT_FALSE(grid.covers(Vec3f(NAN, 0.0f, 0.0f)));
  EXPECT_FALSE(grid.none_within_reach(Vec3f(NAN, 0.0f, 0.0f)));
}

// Pairs at exactly `reach` along an axis (the case where cell indices differ by exactly r), over
// many grid origins and positions near cell faces.
TEST(ProximityGrid, ExactReachAlongAnAxisIsNear) {
  Pcg32 rng(21);
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3d center(rng.uniform(-50.0, 50.0), rng.uniform(-50.0, 50.0), rng.uniform(-5.0, 5.0));
    const Vec3d half(70.0, 10.0, 3.0);  // rows of 3 words
    std::vector<Vec3f> map;
    std::vector<Vec3f> queries;
    for (int i = 0; i < 64; ++i) {
      // Coordinates on a 2^-10 grid: p + 2 is exact in float.
      Vec3f q;
      for (int a = 0; a < 3; ++a) {
        q[a] = static_cast<float>(std::floor((center[a] + rng.uniform(0.01 - half[a], half[a] - 0.01)) * 1024.0) / 1024.0);
      }
      const int axis = static_cast<int>(rng.uniform_below(3));
      const float sign = rng.uniform_below(2) == 0 ? 1.0f : -1.0f;
      Vec3f p = q;
      p[axis] += sign * 2.0f;
      map.push_back(p);
      queries.push_back(q);
    }
    grid.build(map, center, half, {1.0f, 2.0f});
    ASSERT_TRUE(grid.valid());
    for (std::size_t i = 0; i < queries.size(); ++i) {
      ASSERT_LE((queries[i] - map[i]).norm(), 2.0f);
      EXPECT_TRUE(grid.near(queries[i])) << trial << " " << queries[i].transpose();
    }
  }
}

TEST(ProximityGrid, BoundaryCasesOfTheHeader) {
  // Grid origin 0 (center 12, half 10, r 2): cells are [k, k + 1).
  const Vec3d center(12.0, 12.0, 12.0), half(10.0, 10.0, 10.0);
  struct Pair {
    float p, q;
    bool must_be_near;
  };
  for (const Pair c : {Pair{0.99f, 2.98f, true}, Pair{0.01f, 2.0f, true}, Pair{0.0f, 2.0f, true},
                       Pair{0.99f, 2.99f, true}, Pair{0.99f, 3.0f, false}, Pair{0.0f, 2.5f, false},
                       Pair{0.0f, 3.0f, false}}) {
    const std::vector<Vec3f> map = {Vec3f(c.p, 5.0f, 5.0f)};
    grid.build(map, center, half, {1.0f, 2.0f});
    ASSERT_EQ(grid.origin().x(), 0.0);
    const Vec3f q(c.q, 5.0f, 5.0f);
    if (c.must_be_near) {
      EXPECT_TRUE(grid.near(q)) << c.p << " " << c.q;
    }
    if (c.q == 3.0f) {  // cell 3, p's cell 0: index distance 3 > r, not near
      EXPECT_FALSE(grid.near(q)) << c.p << " " << c.q;
    }
  }
  // An origin whose rounding puts a map point onto a cell face: u(p) = 5 - 2^-51 exactly, but
  // (p - o) rounds to 5.0 (tie to even). q is 2 m away (u(q) = 3 - 2^-51, cell 2): without the
  // marking slack p would land in cell 5, off this 5-cell grid, and near(q) would be false.
  const double tiny = std::ldexp(1.0, -51);
  const Vec3d c2(3.0 + tiny, 0.0, 0.0), h2(0.5, 4.0, 4.0);
  const std::vector<Vec3f> map = {Vec3f(5.5f, 0.0f, 0.0f)};
  grid.build(map, c2, h2, {1.0f, 2.0f});
  ASSERT_EQ(grid.origin().x(), 0.5 + tiny);
  ASSERT_EQ(grid.nx(), 5u);
  ASSERT_EQ((5.5 - grid.origin().x()) / grid.cell(), 5.0) << "the face case this test is about";
  EXPECT_EQ(grid.points_marked(), 1u);
  EXPECT_TRUE(grid.near(Vec3f(3.5f, 0.0f, 0.0f)));
}

TEST(ProximityGrid, SlicedBuildsGiveTheSameBits) {
  const Vec3d center(-7.0, 4.0, 2.0), half(15.0, 15.0, 5.0);
  Pcg32 rng(31);
  auto map = uniform_points(rng, 2000, center - half - Vec3d(4, 4, 4), center + half + Vec3d(4, 4, 4));
  map[17] = Vec3f(NAN, 0.0f, 0.0f);
  map[0] = center.cast<float>();
  const ProximityGridParams params{0.5f, 2.0f};
  grid.build(map, center, half, params);
  ASSERT_TRUE(grid.valid());
  EXPECT_EQ(grid.work_done(), grid.total_work());
  const Vec3f probe = map[0];
  for (const std::uint64_t budget : {std::uint64_t{1}, std::uint64_t{7}, std::uint64_t{1000}}) {
    other.begin(map, center, half, params);
    ASSERT_EQ(other.total_work(), grid.total_work());
    std::uint64_t calls = 0;
    bool done = false;
    while (!done) {
      EXPECT_FALSE(other.near(probe)) << "no query may see a half-built grid";
      done = other.step(budget);
      ++calls;
      ASSERT_LE(calls, grid.total_work() + 1);
    }
    EXPECT_EQ(calls, (grid.total_work() + budget - 1) / budget) << budget;
    EXPECT_EQ(other.work_done(), grid.total_work());
    ASSERT_EQ(other.words_used(), grid.words_used());
    EXPECT_EQ(std::memcmp(other.words().data(), grid.words().data(), grid.words_used() * 8), 0) << budget;
    EXPECT_EQ(other.points_marked(), grid.points_marked());
    EXPECT_EQ(other.points_outside(), grid.points_outside());
    EXPECT_EQ(other.points_non_finite(), 1u);
    EXPECT_TRUE(other.near(probe));
  }
  // Bits past nx in a row's last word stay clear (the x dilation masks them).
  const std::uint64_t row = (grid.nx() + 63) / 64;
  ASSERT_NE(grid.nx() % 64, 0u);
  const std::uint64_t past = ~((std::uint64_t{1} << (grid.nx() % 64)) - 1);
  for (std::size_t i = row - 1; i < grid.words_used(); i += row) ASSERT_EQ(grid.words()[i] & past, 0u) << i;
  EXPECT_TRUE(other.step(0)) << "a ready grid stays ready";
}

TEST(ProximityGrid, TooLargeABoxGrowsTheCellAndStaysComplete) {
  const Vec3d center(100.0, -200.0, 0.0), half(400.0, 400.0, 30.0);
  Pcg32 rng(41);
  const auto map = uniform_points(rng, 2000, center - half, center + half);
  grid.build(map, center, half, {1.0f, 2.0f});
  ASSERT_TRUE(grid.valid());
  EXPECT_GT(grid.cell(), 1.0);
  EXPECT_LE(grid.words_used(), ProximityGrid::kCapacityWords);
  // The first 9/8 step that fits: one step finer would not.
  const double finer = grid.cell() / 1.125;
  const double r = std::ceil(2.0 / finer);
  double words = std::ceil((std::ceil(2.0 * half.x() / finer) + 2.0 * r) / 64.0);
  words *= (std::ceil(2.0 * half.y() / finer) + 2.0 * r) * (std::ceil(2.0 * half.z() / finer) + 2.0 * r);
  EXPECT_GT(words, static_cast<double>(ProximityGrid::kCapacityWords));
  EXPECT_EQ(grid.points_marked(), map.size());
  const auto [hits, misses] = check_against_brute_force(grid, map, center, half, 2.0, 42, 20000);
  EXPECT_GT(hits, 500);
  EXPECT_GT(misses, 500);
}

TEST(ProximityGrid, BadPointsAreCountedAndBadQueriesAreFalse) {
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<Vec3f> map = {Vec3f(NAN, 0.0f, 0.0f), Vec3f(0.0f, inf, 0.0f), Vec3f(0.0f, 0.0f, -inf),
                                  Vec3f(0.0f, 0.0f, 0.0f), Vec3f(1000.0f, 0.0f, 0.0f),
                                  Vec3f(0.0f, -12.1f, 0.0f), Vec3f(0.0f, 11.9f, 0.0f)};
  grid.build(map, Vec3d::Zero(), Vec3d(10.0, 10.0, 10.0), {1.0f, 2.0f});
  ASSERT_TRUE(grid.valid());
  EXPECT_EQ(grid.points_non_finite(), 3u);
  EXPECT_EQ(grid.points_outside(), 2u);  // 1000 m away, and 12.1 m (> 10 m + r cells)
  EXPECT_EQ(grid.points_marked(), 2u);   // the origin, and 11.9 m: in the reach margin
  EXPECT_TRUE(grid.near(Vec3f(0.5f, 0.5f, 0.5f)));
  EXPECT_TRUE(grid.near(Vec3f(0.0f, 10.0f, 0.0f)));
  EXPECT_FALSE(grid.near(Vec3f(NAN, 0.0f, 0.0f)));
  EXPECT_FALSE(grid.near(Vec3f(0.0f, NAN, 0.0f)));
  EXPECT_FALSE(grid.near(Vec3f(0.0f, 0.0f, NAN)));
  EXPECT_FALSE(grid.near(Vec3f(inf, 0.0f, 0.0f)));
  EXPECT_FALSE(grid.near(Vec3f(-inf, 0.0f, 0.0f)));
  EXPECT_FALSE(grid.near(Vec3f(1000.0f, 0.0f, 0.0f)));
  EXPECT_FALSE(grid.near(Vec3f(0.0f, 0.0f, -1e30f)));
  EXPECT_FALSE(grid.near(Vec3f(5.0f, 5.0f, 5.0f)));
}

TEST(ProximityGrid, EmptyMapIsReadyAndAllFalse) {
  grid.begin({}, Vec3d(1.0, 2.0, 3.0), Vec3d(20.0, 20.0, 5.0), {1.0f, 2.0f});
  const std::uint64_t words = grid.words_used();
  EXPECT_EQ(grid.total_work(), words * (2 + 4 * 2));  // r = 2: m = 2 passes per direction
  std::uint64_t calls = 1;
  while (!grid.step(4096)) ASSERT_LE(++calls, 1000u);
  EXPECT_EQ(calls, (grid.total_work() + 4095) / 4096);
  EXPECT_TRUE(grid.valid());
  Pcg32 rng(51);
  for (const Vec3f& q : uniform_points(rng, 2000, Vec3d(-30, -30, -10), Vec3d(30, 30, 10))) {
    EXPECT_FALSE(grid.near(q));
  }
  for (const std::uint64_t w : grid.words()) ASSERT_EQ(w, 0u);
}

TEST(ProximityGrid, InvalidInputsAnswerFalse) {
  const std::vector<Vec3f> map = {Vec3f(0.0f, 0.0f, 0.0f)};
  const Vec3f q(0.0f, 0.0f, 0.0f);
  static ProximityGrid fresh;
  EXPECT_TRUE(fresh.ready());
  EXPECT_FALSE(fresh.valid());
  EXPECT_FALSE(fresh.near(q)) << "default constructed";
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    Vec3d center, half;
    ProximityGridParams params;
  };
  for (const Case& c : {Case{Vec3d(nan, 0, 0), Vec3d(10, 10, 10), {}}, Case{Vec3d::Zero(), Vec3d(10, -1, 10), {}},
                        Case{Vec3d::Zero(), Vec3d(1e300, 10, 10), {}}, Case{Vec3d::Zero(), Vec3d(10, 10, 10), {0.0f, 2.0f}},
                        Case{Vec3d::Zero(), Vec3d(10, 10, 10), {1.0f, -1.0f}},
                        Case{Vec3d::Zero(), Vec3d(10, 10, 10), {1.0f, NAN}}}) {
    grid.build(map, Vec3d::Zero(), Vec3d(10, 10, 10), {});
    ASSERT_TRUE(grid.near(q));
    grid.begin(map, c.center, c.half, c.params);
    EXPECT_TRUE(grid.ready());
    EXPECT_FALSE(grid.valid());
    EXPECT_FALSE(grid.near(q));
    EXPECT_TRUE(grid.step(100));
  }
}

TEST(ProximityGrid, ReachZeroMarksOnlyTheCell) {
  const std::vector<Vec3f> map = {Vec3f(0.25f, 0.25f, 0.25f)};
  grid.build(map, Vec3d(0.5, 0.5, 0.5), Vec3d(5, 5, 5), {0.5f, 0.0f});
  ASSERT_TRUE(grid.valid());
  EXPECT_EQ(grid.reach_cells(), 0u);
  EXPECT_EQ(grid.total_work(), grid.words_used() + 1);
  EXPECT_TRUE(grid.near(Vec3f(0.26f, 0.4f, 0.01f)));
  EXPECT_FALSE(grid.near(Vec3f(0.6f, 0.25f, 0.25f)));
}

TEST(ProximityGrid, RebuildForgetsTheOldMap) {
  const std::vector<Vec3f> a = {Vec3f(3.0f, 3.0f, 0.0f)};
  const std::vector<Vec3f> b = {Vec3f(-3.0f, -3.0f, 0.0f)};
  grid.build(a, Vec3d::Zero(), Vec3d(10, 10, 3), {});
  EXPECT_TRUE(grid.near(a[0]));
  grid.build(b, Vec3d::Zero(), Vec3d(10, 10, 3), {});
  EXPECT_FALSE(grid.near(a[0]));
  EXPECT_TRUE(grid.near(b[0]));
}

// The start-up search's case: a 130k-point map in a 220 x 220 x 40 m box at 1 m cells. The work
// is the documented W (2 + 4m) + N and the cells are as coarse as the capacity forces.
TEST(ProximityGrid, WorkBoundOfAStartUpSizedMap) {
  const Vec3d center(10.0, -20.0, 2.0), half(110.0, 110.0, 20.0);
  Pcg32 rng(61);
  const auto map = uniform_points(rng, 130000, center - half, center + half);
  grid.begin(map, center, half, {1.0f, 2.0f});
  ASSERT_TRUE(grid.valid());
  const std::uint64_t m = grid.reach_cells() == 0 ? 0 : (grid.reach_cells() <= 1 ? 1 : grid.reach_cells() <= 3 ? 2 : 3);
  EXPECT_EQ(grid.total_work(), grid.words_used() * (2 + 4 * m) + map.size());
  EXPECT_LE(grid.total_work(), map.size() + 26 * ProximityGrid::kCapacityWords);
  std::uint64_t calls = 0;
  while (!grid.step(50000)) ASSERT_LE(++calls, 1000u);
  EXPECT_EQ(calls + 1, (grid.total_work() + 49999) / 50000);
  EXPECT_EQ(grid.points_marked(), map.size());
  std::printf("220x220x40 m, 130k points: cell %.4f m, r %u, dims %u x %u x %u, %zu words, work %llu units\n",
              grid.cell(), grid.reach_cells(), grid.nx(), grid.ny(), grid.nz(), grid.words_used(),
              static_cast<unsigned long long>(grid.total_work()));
}

}  // namespace
}  // namespace v2xloc
