#include "host_sim/common/json.hpp"
#include "host_sim/common/rng.hpp"

#include <gtest/gtest.h>

#include <string>

namespace v2xloc::sim {
namespace {

TEST(HostSimCommon, JsonRoundTrip) {
  Json j = Json::object();
  j.set("name", "sim \"0\"\n");
  j.set("pi", 3.141592653589793);
  j.set("n", 42);
  j.set("list", Json::array_of(std::vector<double>{1.5, -2.0, 1e-7}));
  Json inner = Json::object();
  inner.set("ok", true);
  j.set("inner", inner);
  Json back;
  std::string err;
  ASSERT_TRUE(Json::parse(j.dump(2), back, err)) << err;
  EXPECT_EQ(back["name"].as_string(), "sim \"0\"\n");
  EXPECT_EQ(back["pi"].as_number(), 3.141592653589793);
  EXPECT_EQ(back["n"].as_int(), 42);
  EXPECT_EQ(back["list"].as_numbers(), (std::vector<double>{1.5, -2.0, 1e-7}));
  EXPECT_TRUE(back["inner"]["ok"].as_bool());
  EXPECT_EQ(back.dump(), j.dump());
  EXPECT_FALSE(Json::parse("{\"a\": [1, 2,}", back, err));
}

TEST(HostSimCommon, RngIsSeededAndGaussianHasUnitVariance) {
  Rng a(7), b(7), c(8);
  EXPECT_EQ(a.next_u64(), b.next_u64());
  EXPECT_NE(a.next_u64(), c.next_u64());
  Rng g(3);
  double s = 0, s2 = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double v = g.gaussian();
    s += v;
    s2 += v * v;
  }
  EXPECT_NEAR(s / n, 0.0, 0.01);
  EXPECT_NEAR(s2 / n, 1.0, 0.02);
  EXPECT_NE(derive_seed(1, {2, 3}), derive_seed(1, {3, 2}));
}

}  // namespace
}  // namespace v2xloc::sim
