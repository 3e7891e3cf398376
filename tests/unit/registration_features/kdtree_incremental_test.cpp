// The k-d tree built in slices (a map rebuilt beside the registration) is the tree build()
// makes, node for node, and the early-exit "anything within" query answers exactly what the
// bounded nearest query does.
#include "v2xloc/algo/search/kdtree.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "random_points.hpp"

namespace v2xloc {
namespace {

using test::random_points;

static KdTreeStorage<Vec3f, 4000> whole;
static KdTreeStorage<Vec3f, 4000> sliced;

TEST(KdTreeIncremental, SlicedBuildIsTheSameTree) {
  const auto pts = random_points<Vec3f>(4000, 17, 30.0f);
  const KdBuildResult a = whole.build(pts);
  ASSERT_EQ(a.status, KdBuildStatus::kOk);
  KdBuildResult b = sliced.begin_build(pts);
  int steps = 0;
  while (!sliced.tree.build_step(500, b)) {
    EXPECT_TRUE(sliced.tree.empty()) << "no query may see a half-built tree";
    ASSERT_LT(++steps, 10000);
  }
  EXPECT_GT(steps, 20) << "a 500-point quota must take many steps for 4000 points";
  EXPECT_EQ(b.status, a.status);
  EXPECT_EQ(b.nodes, a.nodes);
  EXPECT_EQ(b.depth, a.depth);
  EXPECT_EQ(std::memcmp(whole.indices, sliced.indices, sizeof(whole.indices)), 0);
  EXPECT_EQ(std::memcmp(whole.nodes, sliced.nodes, sizeof(KdNode) * a.nodes), 0);
  for (const Vec3f& q : random_points<Vec3f>(200, 18, 30.0f)) {
    Neighbor x{}, y{};
    ASSERT_EQ(whole.tree.nearest(q, x).count, 1u);
    ASSERT_EQ(sliced.tree.nearest(q, y).count, 1u);
    EXPECT_EQ(x.index, y.index);
  }
}

// The estimate of the work a spread build has left (the period budget's forecast): positive
// while building, never growing from one step to the next, at most the quota when the next step
// finishes the tree, zero when done.
TEST(KdTreeIncremental, WorkLeftShrinksToZero) {
  const auto pts = random_points<Vec3f>(4000, 19, 30.0f);
  KdBuildResult b = sliced.begin_build(pts);
  std::size_t left = sliced.tree.build_work_left();
  EXPECT_GE(left, pts.size()) << "every point is touched at least once";
  const std::size_t quota = 500;
  for (int steps = 0;; ++steps) {
    ASSERT_LT(steps, 10000);
    const bool last_step_expected = sliced.tree.build_work_left() <= quota;
    const bool done = sliced.tree.build_step(quota, b);
    const std::size_t now = sliced.tree.build_work_left();
    EXPECT_LE(now, left);
    left = now;
    if (last_step_expected) {
      EXPECT_TRUE(done) << "the estimate fit the quota: the step must finish the tree";
    }
    if (done) break;
  }
  EXPECT_EQ(sliced.tree.build_work_left(), 0u);
}

TEST(KdTreeIncremental, EmptyAndNonFiniteInputsFinishAtOnce) {
  const std::vector<Vec3f> none(5, Vec3f(NAN, 0.0f, 0.0f));
  KdBuildResult r = sliced.begin_build(none);
  EXPECT_TRUE(sliced.tree.build_step(1, r));
  EXPECT_EQ(r.status, KdBuildStatus::kEmpty);
  EXPECT_EQ(r.non_finite_dropped, 5u);
  EXPECT_TRUE(sliced.tree.empty());
}

TEST(KdTreeAnyWithin, AnswersExactlyWhatTheBoundedNearestDoes) {
  const auto pts = random_points<Vec3f>(3000, 21, 20.0f);
  ASSERT_EQ(whole.build(pts).status, KdBuildStatus::kOk);
  int hits = 0, misses = 0;
  for (const Vec3f& q : random_points<Vec3f>(2000, 22, 25.0f)) {
    for (const float bound : {0.01f, 0.25f, 1.0f, 4.0f}) {
      Neighbor nb{};
      const bool nearest = whole.tree.nearest_within(q, bound, KdTree<Vec3f>::kNoHint, nb).count > 0;
      const bool any = whole.tree.any_within(q, bound);
      ASSERT_EQ(any, nearest) << bound;
      (any ? hits : misses) += 1;
    }
  }
  EXPECT_GT(hits, 500);
  EXPECT_GT(misses, 500);
  EXPECT_FALSE(whole.tree.any_within(Vec3f(NAN, 0.0f, 0.0f), 4.0f));
}

}  // namespace
}  // namespace v2xloc
