// The k-d tree's fast paths give exactly the plain queries' answers: warm-started and
// distance-bounded nearest, the first-hit "is anything closer" query, and the shared
// neighbourhood lists (also when their storage overflows).
#include "v2xloc/algo/search/kdtree.hpp"

#include <gtest/gtest.h>

#include "random_points.hpp"

#include <random>
#include <vector>

namespace v2xloc {
namespace {

using test::random_points;

static KdTreeStorage<Vec3f, 3000> tree3;
static KdTreeStorage<Feature33, 1500> tree33;

template <class P, class Storage>
void check_nearest_variants(Storage& storage, std::size_t n, float scale, std::uint32_t seed) {
  const auto pts = random_points<P>(n, seed, scale);
  ASSERT_EQ(storage.build(pts, 1u << 30).status, KdBuildStatus::kOk);
  const KdTree<P>& tree = storage.tree;
  const auto queries = random_points<P>(300, seed + 1, scale);
  std::mt19937 rng(seed + 2);
  for (const P& q : queries) {
    Neighbor plain{}, seeded{};
    ASSERT_EQ(tree.nearest(q, plain).count, 1u);
    const auto hint = static_cast<std::uint32_t>(rng() % (n + 10));  // some out of range
    ASSERT_EQ(tree.nearest(q, hint, seeded).count, 1u);
    EXPECT_EQ(seeded.index, plain.index);
    EXPECT_EQ(seeded.squared_distance, plain.squared_distance);
    EXPECT_EQ(KdTree<P>::squared_distance(q, pts[plain.index]), plain.squared_distance);

    // Bounded: found iff the nearest is within the bound, and then the same one.
    for (const float factor : {0.5f, 1.0f, 2.0f}) {
      const float bound = plain.squared_distance * factor;
      Neighbor within{};
      const KdQueryResult r = tree.nearest_within(q, bound, hint, within);
      ASSERT_EQ(r.count, plain.squared_distance <= bound ? 1u : 0u) << factor;
      if (r.count == 1) {
        EXPECT_EQ(within.index, plain.index);
      }
    }

    // has_closer: against the nearest itself -> nothing closer; against the second -> yes.
    bool found = true;
    tree.has_closer(q, plain, found);
    EXPECT_FALSE(found);
    Neighbor two[2];
    ASSERT_EQ(tree.knn(q, 2, two).count, 2u);
    tree.has_closer(q, two[1], found);
    EXPECT_TRUE(found);
    // Equal distance, larger index than the nearest: the nearest is closer (index tie-break).
    tree.has_closer(q, Neighbor{plain.index + 1, plain.squared_distance}, found);
    EXPECT_TRUE(found);
  }
}

TEST(KdTreeFastPaths, NearestVariantsMatchPlainNearest3D) {
  check_nearest_variants<Vec3f>(tree3, 3000, 10.0f, 11);
}

TEST(KdTreeFastPaths, NearestVariantsMatchPlainNearest33D) {
  check_nearest_variants<Feature33>(tree33, 1500, 50.0f, 12);
}

TEST(KdTreeFastPaths, EmptyTreeAndNonFiniteQueries) {
  KdTree<Vec3f> empty;
  Neighbor nb{7, 1.0f};
  bool found = true;
  EXPECT_EQ(empty.nearest(Vec3f::Zero(), 0u, nb).count, 0u);
  EXPECT_EQ(empty.nearest_within(Vec3f::Zero(), 1.0f, 0u, nb).count, 0u);
  EXPECT_EQ(empty.has_closer(Vec3f::Zero(), nb, found).count, 0u);
  EXPECT_FALSE(found);
  const auto pts = random_points<Vec3f>(100, 3, 1.0f);
  tree3.build(pts);
  const Vec3f nan(NAN, 0.0f, 0.0f);
  EXPECT_EQ(tree3.tree.nearest(nan, 0u, nb).count, 0u);
  EXPECT_EQ(tree3.tree.nearest_within(nan, 1.0f, 0u, nb).count, 0u);
  EXPECT_EQ(tree3.tree.nearest_within(pts[0], -1.0f, 0u, nb).count, 0u);
  // A zero bound finds an exact duplicate only.
  EXPECT_EQ(tree3.tree.nearest_within(pts[5], 0.0f, KdTree<Vec3f>::kNoHint, nb).count, 1u);
  EXPECT_EQ(nb.index, 5u);
}

static KdNeighborhoods::Slot entries[3000 * 64];
static std::uint32_t begin_storage[3000];
static std::uint8_t count_storage[3000];

// Lists searched once at (1.5, 64) answer (radius', max_nn') requests exactly as hybrid does,
// with ample storage and with storage for a fraction of the points (the rest re-searched).
TEST(KdNeighborhoods, PrefixRequestsEqualHybridSearches) {
  auto pts = random_points<Vec3f>(3000, 21, 6.0f);
  pts[10] = Vec3f(NAN, 0.0f, 0.0f);
  pts[11] = pts[12];  // duplicate: distance ties break by index
  ASSERT_EQ(tree3.build(pts).status, KdBuildStatus::kOk);
  for (const std::size_t capacity : {sizeof(entries) / sizeof(entries[0]), std::size_t{5000}}) {
    KdNeighborhoods lists(tree3.tree);
    lists.build(1.5f, 64, std::span<KdNeighborhoods::Slot>(entries, capacity), begin_storage,
                count_storage);
    EXPECT_EQ(lists.cached_points() + lists.not_cached(), pts.size());
    if (capacity == 5000) {
      EXPECT_GT(lists.not_cached(), 0u);
    }
    Neighbor a[64], b[64];
    for (std::size_t i = 0; i < pts.size(); i += 7) {
      for (const auto& [radius, max_nn] : {std::pair{1.5f, std::size_t{64}}, std::pair{0.8f, std::size_t{30}},
                                           std::pair{1.5f, std::size_t{10}}, std::pair{2.0f, std::size_t{64}}}) {
        const KdQueryResult got = lists.get(i, radius, max_nn, std::span<Neighbor>(a, max_nn));
        const KdQueryResult want = tree3.tree.hybrid(pts[i], radius, max_nn, std::span<Neighbor>(b, max_nn));
        ASSERT_EQ(got.count, want.count) << i << " r " << radius << " nn " << max_nn;
        for (std::uint32_t k = 0; k < got.count; ++k) {
          EXPECT_EQ(a[k].index, b[k].index);
          EXPECT_EQ(a[k].squared_distance, b[k].squared_distance);
        }
      }
    }
  }
  // Without storage every request is a search.
  KdNeighborhoods none(tree3.tree);
  none.build(1.5f, 64, {}, {}, {});
  EXPECT_EQ(none.cached_points(), 0u);
  Neighbor a[30], b[30];
  EXPECT_EQ(none.get(3, 1.0f, 30, a).count, tree3.tree.hybrid(pts[3], 1.0f, 30, b).count);
}

}  // namespace
}  // namespace v2xloc
