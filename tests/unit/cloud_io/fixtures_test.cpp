// PCD files written by Open3D (tests/data/pcd_fixtures, made by tools/fixtures/make_pcd_fixtures.py)
// read back with exactly the values Open3D was given.
#include "test_util.hpp"

#include <gtest/gtest.h>

namespace v2xloc::cloud_io {
namespace {

using test::Expected;
using test::fixture;

void expect_matches(const std::string& file, const std::string& stem) {
  SCOPED_TRACE(file);
  Expected e;
  ASSERT_TRUE(test::read_expected(fixture(stem + ".expected.txt"), e));
  ASSERT_FALSE(e.rows.empty());
  PointCloud c;
  std::string error;
  ASSERT_TRUE(read_pcd(fixture(file), c, error)) << error;
  ASSERT_EQ(c.size(), e.rows.size());
  const bool normals = e.columns.size() >= 6;
  const bool intensity = e.columns.size() == 7;
  EXPECT_EQ(c.has_normals(), normals);
  EXPECT_EQ(c.has_intensity(), intensity);
  EXPECT_FALSE(c.has_time());
  EXPECT_TRUE(c.has_viewpoint);
  EXPECT_EQ(c.height, 1u);
  EXPECT_EQ(c.width, c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    const std::vector<float>& r = e.rows[i];
    ASSERT_EQ(c.points[i], Eigen::Vector3f(r[0], r[1], r[2])) << "point " << i;
    if (normals) {
      ASSERT_EQ(c.normals[i], Eigen::Vector3f(r[3], r[4], r[5])) << "normal " << i;
    }
    if (intensity) {
      ASSERT_EQ(c.intensity[i], r[6]) << "intensity " << i;
    }
  }
}

TEST(PcdFixtures, XyzAllEncodings) {
  expect_matches("xyz_ascii.pcd", "xyz");
  expect_matches("xyz_binary.pcd", "xyz");
  expect_matches("xyz_binary_compressed.pcd", "xyz");
}

TEST(PcdFixtures, XyzFloat64Coordinates) { expect_matches("xyz_f64_binary.pcd", "xyz"); }

TEST(PcdFixtures, NormalsAllEncodings) {
  expect_matches("xyzn_ascii.pcd", "xyzn");
  expect_matches("xyzn_binary.pcd", "xyzn");
  expect_matches("xyzn_binary_compressed.pcd", "xyzn");
}

TEST(PcdFixtures, NormalsAndIntensityAllEncodings) {
  expect_matches("xyzni_ascii.pcd", "xyzni");
  expect_matches("xyzni_binary.pcd", "xyzni");
  expect_matches("xyzni_binary_compressed.pcd", "xyzni");
}

TEST(PcdFixtures, LegacyOpen3dWithRgbSkipsColour) {
  for (const char* f : {"xyzn_rgb_legacy_ascii.pcd", "xyzn_rgb_legacy_binary.pcd",
                        "xyzn_rgb_legacy_binary_compressed.pcd"}) {
    expect_matches(f, "xyzn");
    PointCloud c;
    std::string error;
    ReadStats stats;
    ASSERT_TRUE(read_pcd(fixture(f), c, error, {}, &stats)) << error;
    EXPECT_EQ(stats.skipped_fields, std::vector<std::string>{"rgb"});
  }
}

TEST(PcdFixtures, CompressedFixtureReallyUsesBackReferences) {
  // Guards the test's value: the plane's repeated values must make Open3D emit LZF matches.
  std::vector<std::uint8_t> bytes;
  std::string error;
  ASSERT_TRUE(read_file_bytes(fixture("xyz_binary_compressed.pcd"), bytes, error)) << error;
  EXPECT_LT(bytes.size(), 240u * 12u);
}

}  // namespace
}  // namespace v2xloc::cloud_io
