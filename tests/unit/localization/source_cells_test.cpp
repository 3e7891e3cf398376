#include "v2xloc/algo/localization/source_cells.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <random>
#include <vector>

namespace v2xloc {
namespace {

SourceCells& fresh_cells() {
  static SourceCells cells;  // ~4 MB: static storage, as in the map
  cells.clear();
  return cells;
}

struct Stored {
  Vec3f p;
  int source;
};

// The definition any_around() must meet: a stored point of an allowed source whose cell is
// within one cell of p's cell on every axis.
bool brute_force_around(const std::vector<Stored>& stored, const Vec3f& p, double cell, std::int32_t level,
                        SourceCells::Mask allowed) {
  std::int32_t kp[3];
  if (!SourceCells::cell_key(p, cell, level, kp)) return false;
  for (const Stored& s : stored) {
    if (!(allowed & (1u << s.source))) continue;
    std::int32_t kq[3];
    if (!SourceCells::cell_key(s.p, cell, level, kq)) continue;
    if (std::abs(kq[0] - kp[0]) <= 1 && std::abs(kq[1] - kp[1]) <= 1 && std::abs((kq[2] - kp[2]) / 4) <= 1 &&
        (kq[2] - kp[2]) % 4 == 0)
      return true;
  }
  return false;
}

TEST(SourceCells, AnyAroundMatchesBruteForceThroughAddsAndRemoves) {
  SourceCells& cells = fresh_cells();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coord(-3.0f, 3.0f);
  const double cell = 0.15;
  std::vector<Stored> stored;
  for (int i = 0; i < 600; ++i) stored.push_back({Vec3f(coord(rng), coord(rng), coord(rng) * 0.3f), i % 4});
  std::vector<std::uint32_t> slot_of(stored.size(), SourceCells::kNoCell);
  for (std::size_t i = 0; i < stored.size(); ++i) {
    std::int32_t key[3];
    if (!SourceCells::cell_key(stored[i].p, cell, 0, key)) continue;
    slot_of[i] = cells.add(key, static_cast<SourceCells::Mask>(1u << stored[i].source));
    ASSERT_NE(slot_of[i], SourceCells::kNoCell);
  }
  for (std::size_t i = 0; i < stored.size(); ++i)  // source 2 leaves: its bits go, its points no longer count
    if (stored[i].source == 2) cells.remove_at(slot_of[i], 0x4);
  std::vector<Stored> live;
  for (const Stored& s : stored)
    if (s.source != 2) live.push_back(s);
  const SourceCells::Mask masks[] = {0xF, 0x1, 0x4, 0xA, 0x0};
  int checked = 0, found = 0;
  for (int q = 0; q < 2000; ++q) {
    const Vec3f p(coord(rng), coord(rng), coord(rng) * 0.3f);
    for (SourceCells::Mask m : masks) {
      const bool expect = brute_force_around(live, p, cell, 0, m);
      ASSERT_EQ(cells.any_around(p, cell, 0, m), expect) << "query " << q << " mask " << m;
      ++checked;
      found += expect ? 1 : 0;
    }
  }
  EXPECT_GT(found, checked / 10);  // both answers exercised
  EXPECT_LT(found, checked);
  EXPECT_EQ(cells.dropped(), 0u);
}

TEST(SourceCells, LevelsShareTheTableWithoutMixing) {
  SourceCells& cells = fresh_cells();
  std::int32_t key[3];
  ASSERT_TRUE(SourceCells::cell_key(Vec3f(1.0f, 1.0f, 1.0f), 2.0, 1, key));
  const std::uint32_t slot = cells.add(key, 0x1);
  ASSERT_NE(slot, SourceCells::kNoCell);
  EXPECT_TRUE(cells.any_around(Vec3f(1.0f, 1.0f, 1.0f), 2.0, 1, 0x1));
  EXPECT_FALSE(cells.any_around(Vec3f(1.0f, 1.0f, 1.0f), 2.0, 0, 0x1));  // same key, other level
  EXPECT_FALSE(cells.any_around(Vec3f(1.0f, 1.0f, 1.0f), 2.0, 1, 0x2));  // other source
  cells.remove_at(slot, 0x1);
  EXPECT_FALSE(cells.any_around(Vec3f(1.0f, 1.0f, 1.0f), 2.0, 1, 0x1));
  ASSERT_EQ(cells.add(key, 0x2), slot);  // a cell keeps its slot
  cells.remove_at(slot, 0x2);
  EXPECT_EQ(cells.bits(key), 0u);
  EXPECT_EQ(cells.used_cells(), 1u);  // an emptied cell stays in its chain until a rebuild
}

TEST(SourceCells, FarOrNonFinitePointsHaveNoCell) {
  std::int32_t key[3];
  EXPECT_FALSE(SourceCells::cell_key(Vec3f(1e30f, 0.0f, 0.0f), 0.15, 0, key));
  EXPECT_FALSE(SourceCells::cell_key(Vec3f(std::nanf(""), 0.0f, 0.0f), 0.15, 0, key));
  EXPECT_FALSE(fresh_cells().any_around(Vec3f(std::nanf(""), 0.0f, 0.0f), 0.15, 0, 0xFFFF));
}

TEST(SourceCells, FullEnoughAsksTheOwnerForARebuild) {
  SourceCells& cells = fresh_cells();
  std::size_t added = 0, attempts = 0;
  std::int32_t x = 0;
  const auto fill_to = [&](std::size_t used) {
    for (; added < used; ++x, ++attempts) {
      const std::int32_t key[3] = {x, 3 * x, 0};  // a line of cells: the hash clusters them
      if (cells.add(key, 0x1) != SourceCells::kNoCell) ++added;
    }
  };
  const std::size_t full = SourceCells::kSlots * SourceCells::kRebuildQuarters / 4;  // host half, EMBEDDED 3/4
  fill_to(full - 1);
  EXPECT_FALSE(cells.needs_rebuild()) << "chains still short";
  fill_to(full);
  EXPECT_TRUE(cells.needs_rebuild());
  EXPECT_EQ(cells.used_cells(), added);
  EXPECT_EQ(cells.used_cells() + cells.dropped(), attempts);  // a cell without a slot is counted
  cells.clear();
  EXPECT_FALSE(cells.needs_rebuild());
}

}  // namespace
}  // namespace v2xloc
