#include "v2xloc/algo/core/det_math.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>

namespace v2xloc {
namespace {

TEST(DetMath, MatchesLibmClosely) {
  for (int i = -20000; i <= 20000; ++i) {
    const double x = i * 0.00137;
    EXPECT_NEAR(det::sin(x), std::sin(x), 2e-15) << x;
    EXPECT_NEAR(det::cos(x), std::cos(x), 2e-15) << x;
    EXPECT_NEAR(det::atan(x), std::atan(x), 2e-15) << x;
  }
  for (int i = -100; i <= 100; ++i) {
    for (int j = -100; j <= 100; ++j) {
      const double y = i * 0.37, x = j * 0.29;
      EXPECT_NEAR(det::atan2(y, x), std::atan2(y, x), 4e-15) << y << " " << x;
    }
  }
  for (int i = -1000; i <= 1000; ++i) {
    const double x = i / 1000.0;
    EXPECT_NEAR(det::acos(x), std::acos(x), 1e-14) << x;
    EXPECT_NEAR(det::asin(x), std::asin(x), 1e-14) << x;
  }
}

TEST(DetMath, EdgeCases) {
  EXPECT_TRUE(std::isnan(det::sin(NAN)));
  EXPECT_TRUE(std::isnan(det::cos(INFINITY)));
  EXPECT_TRUE(std::isnan(det::acos(1.5)));
  EXPECT_DOUBLE_EQ(det::atan2(0.0, -1.0), det::kPi);
  EXPECT_DOUBLE_EQ(det::atan2(1.0, 0.0), det::kHalfPi);
  EXPECT_DOUBLE_EQ(det::atan2(-1.0, 0.0), -det::kHalfPi);
  EXPECT_NEAR(det::wrap_pi(3.0 * det::kPi), det::kPi, 1e-15);
  EXPECT_NEAR(det::wrap_pi(-7.0), -7.0 + 2.0 * det::kPi, 1e-15);
}

TEST(DetMath, FloorToIntMatchesStdFloor) {
  const float edges[] = {0.0f, -0.0f, 1.0f, -1.0f, 0.5f, -0.5f, 1e-30f, -1e-30f, 0.99999994f, -0.99999994f,
                         1234567.0f, -1234567.5f, 8388607.5f, -8388608.0f, 2.0e9f, -2.0e9f};
  for (const float x : edges) EXPECT_EQ(det::floor_to_int(x), static_cast<std::int32_t>(std::floor(x))) << x;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-2000.0f, 2000.0f);
  for (int i = 0; i < 100000; ++i) {
    const float x = u(rng);
    ASSERT_EQ(det::floor_to_int(x), static_cast<std::int32_t>(std::floor(x))) << x;
  }
}

TEST(DetMath, FloorToIntOfDoubleMatchesStdFloor) {
  const double edges[] = {0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 1e-300, -1e-300, 0.9999999999999999, -0.9999999999999999,
                          -1073741823.5, 1073741823.9999998, 2.0e9, -2.0e9, 4503599627370495.5 / 4194304.0};
  for (const double x : edges) EXPECT_EQ(det::floor_to_int(x), static_cast<std::int32_t>(std::floor(x))) << x;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-2000.0, 2000.0);
  for (int i = 0; i < 100000; ++i) {
    const double x = u(rng);
    ASSERT_EQ(det::floor_to_int(x), static_cast<std::int32_t>(std::floor(x))) << x;
  }
}

}  // namespace
}  // namespace v2xloc
