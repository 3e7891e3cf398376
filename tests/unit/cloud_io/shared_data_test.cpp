// The real clouds in tests/data (PCL's bunny PCDs, small_gicp's outdoor PLYs; origin and licences in
// tests/data/README.md), read through V2XLOC_SHARED_DATA_DIR.
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <filesystem>

namespace v2xloc::cloud_io {
namespace {

std::string shared(const std::string& rel) { return std::string(V2XLOC_SHARED_DATA_DIR) + "/" + rel; }

TEST(SharedData, BunnyPcdAsciiAsPclWritesIt) {
  const std::string path = shared("bunny_pair/bun0.pcd");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared data absent: " << path;
  PointCloud c;
  std::string error;
  ReadStats stats;
  ASSERT_TRUE(read_pcd(path, c, error, {}, &stats)) << error;
  ASSERT_EQ(c.size(), 397u);
  ASSERT_TRUE(c.has_normals());
  EXPECT_EQ(stats.skipped_fields, std::vector<std::string>{"curvature"});
  // First data line: 0.0054215998 0.11349 0.040748999 -0.16884723 -0.45159745 -0.87609947 ...
  EXPECT_EQ(c.points[0], Eigen::Vector3f(0.0054215998f, 0.11349f, 0.040748999f));
  EXPECT_EQ(c.normals[0], Eigen::Vector3f(-0.16884723f, -0.45159745f, -0.87609947f));
  const Eigen::Vector3f extent = [&] {
    Eigen::Vector3f lo = c.points[0], hi = c.points[0];
    for (const auto& p : c.points) { lo = lo.cwiseMin(p); hi = hi.cwiseMax(p); }
    return Eigen::Vector3f(hi - lo);
  }();
  EXPECT_GT(extent.maxCoeff(), 0.1f);  // object about 0.15 m
  EXPECT_LT(extent.maxCoeff(), 0.25f);

  PointCloud c4;
  ASSERT_TRUE(read_pcd(shared("bunny_pair/bun4.pcd"), c4, error)) << error;
  EXPECT_EQ(c4.size(), 361u);
}

TEST(SharedData, OutdoorPlyBinaryWithScalarIntensity) {
  for (const char* name : {"outdoor_lidar_pair/source.ply", "outdoor_lidar_pair/target.ply"}) {
    const std::string path = shared(name);
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared data absent: " << path;
    PointCloud c;
    std::string error;
    ReadStats stats;
    ASSERT_TRUE(read_ply(path, c, error, {}, &stats)) << error;
    EXPECT_GT(c.size(), 60000u);
    EXPECT_LT(c.size(), 80000u);
    EXPECT_TRUE(c.has_intensity());
    EXPECT_EQ(stats.non_finite, 0u);
    double max_range = 0.0;
    for (const auto& p : c.points) max_range = std::max(max_range, static_cast<double>(p.norm()));
    EXPECT_GT(max_range, 10.0);   // an outdoor scan
    EXPECT_LT(max_range, 500.0);  // no garbage from misread bytes

    // Our PCD writer round-trips the real scan exactly.
    std::vector<std::uint8_t> bytes;
    ASSERT_TRUE(encode_pcd(c, PcdEncoding::kBinaryCompressed, bytes, error)) << error;
    PointCloud r;
    ASSERT_TRUE(parse_pcd(bytes, r, error)) << error;
    ASSERT_EQ(r.points, c.points);
    ASSERT_EQ(r.intensity, c.intensity);
  }
}

}  // namespace
}  // namespace v2xloc::cloud_io
