#include "v2xloc/algo/core/bounded_vector.hpp"

#include <gtest/gtest.h>

namespace v2xloc {
namespace {

TEST(BoundedVector, OverflowIsCountedNotWritten) {
  FixedVector<int, 3> v;
  EXPECT_TRUE(v.push_back(1));
  EXPECT_TRUE(v.push_back(2));
  EXPECT_TRUE(v.push_back(3));
  EXPECT_FALSE(v.push_back(4));
  EXPECT_FALSE(v.push_back(5));
  EXPECT_EQ(v.size(), 3u);
  EXPECT_EQ(v.dropped(), 2u);
  EXPECT_EQ(v[2], 3);
  v.resize(10);
  EXPECT_EQ(v.size(), 3u);
  EXPECT_EQ(v.dropped(), 9u);
  v.clear();
  EXPECT_TRUE(v.empty());
  EXPECT_EQ(v.dropped(), 0u);
}

TEST(BoundedVector, ViewOverCallerStorage) {
  int storage[2];
  BoundedVector<int> v{std::span<int>(storage)};
  v.push_back(7);
  v.push_back(8);
  v.push_back(9);
  EXPECT_EQ(v.span().size(), 2u);
  EXPECT_EQ(storage[1], 8);
  EXPECT_EQ(v.dropped(), 1u);
}

}  // namespace
}  // namespace v2xloc
