#include "v2xloc/algo/core/det_math.hpp"

#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace v2xloc
