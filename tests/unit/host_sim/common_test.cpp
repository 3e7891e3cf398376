#include "host_sim/common/text_file.hpp"
#include "host_sim/common/rng.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include <unistd.h>

namespace v2xloc::sim {
namespace {

TEST(HostSimCommon, TextFileReadRefusesFilesAboveTheCap) {
  const std::string path = std::string(V2XLOC_BINARY_DIR) + "/text_file_cap_" + std::to_string(::getpid()) + ".txt";
  std::string err, back;
  ASSERT_TRUE(write_text_file(path, std::string(1000, 'x'), err)) << err;
  ASSERT_TRUE(read_text_file(path, 1000, back, err)) << err;
  EXPECT_EQ(back.size(), 1000u);
  EXPECT_FALSE(read_text_file(path, 999, back, err));
  EXPECT_NE(err.find("larger than 999 bytes"), std::string::npos) << err;
  EXPECT_FALSE(read_text_file(path + ".missing", 1000, back, err));
  EXPECT_NE(err.find("cannot open"), std::string::npos) << err;
  std::remove(path.c_str());
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
