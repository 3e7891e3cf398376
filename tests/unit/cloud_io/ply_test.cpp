// PLY reader on hand-written files: ascii, other elements before the vertex, list properties,
// double / integer properties, big endian, CloudCompare's scalar_intensity.
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <cstring>

namespace v2xloc::cloud_io {
namespace {

std::vector<std::uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }

TEST(PlyReader, AsciiWithFacesBeforeVerticesAndNormals) {
  const std::string ply =
      "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\n"
      "element face 2\r\nproperty list uchar int vertex_indices\r\n"
      "element vertex 3\r\nproperty double x\r\nproperty double y\r\nproperty float z\r\n"
      "property uchar red\r\nproperty float nx\r\nproperty float ny\r\nproperty float nz\r\n"
      "property float intensity\r\nend_header\r\n"
      "3 0 1 2\r\n4 0 1 2 0\r\n"
      "1.5 -2 3e2 255 0 0 1 10\r\n0 0 0 0 1 0 0 20\r\n-1 -1 -1 7 0 1 0 30\r\n";
  PointCloud c;
  std::string error;
  ReadStats stats;
  ASSERT_TRUE(parse_ply(bytes_of(ply), c, error, {}, &stats)) << error;
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c.points[0], Eigen::Vector3f(1.5f, -2.0f, 300.0f));
  EXPECT_EQ(c.points[2], Eigen::Vector3f(-1.0f, -1.0f, -1.0f));
  EXPECT_EQ(c.normals[1], Eigen::Vector3f(1.0f, 0.0f, 0.0f));
  EXPECT_EQ(c.intensity, (std::vector<float>{10.0f, 20.0f, 30.0f}));
  EXPECT_EQ(stats.skipped_fields, std::vector<std::string>{"red"});
}

TEST(PlyReader, BinaryLittleEndianWithScalarIntensityAndIntCoordinates) {
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty int x\nproperty short y\n"
      "property float z\nproperty float scalar_intensity\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n";
  std::vector<std::uint8_t> b = bytes_of(ply);
  auto put = [&](auto v) {
    std::uint8_t raw[sizeof(v)];
    std::memcpy(raw, &v, sizeof(v));
    b.insert(b.end(), raw, raw + sizeof(v));
  };
  put(std::int32_t{-7}); put(std::int16_t{300}); put(0.25f); put(99.0f);
  put(std::int32_t{1}); put(std::int16_t{-2}); put(-0.5f); put(1.0f);
  PointCloud c;
  std::string error;
  ASSERT_TRUE(parse_ply(b, c, error)) << error;
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[0], Eigen::Vector3f(-7.0f, 300.0f, 0.25f));
  EXPECT_EQ(c.points[1], Eigen::Vector3f(1.0f, -2.0f, -0.5f));
  EXPECT_EQ(c.intensity, (std::vector<float>{99.0f, 1.0f}));
}

TEST(PlyReader, BinaryBigEndian) {
  std::vector<std::uint8_t> b =
      bytes_of("ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\n"
               "property float y\nproperty double z\nend_header\n");
  // 1.0f = 3f800000, -2.0f = c0000000, 0.5 (double) = 3fe0000000000000
  for (std::uint8_t v : {0x3f, 0x80, 0x00, 0x00, 0xc0, 0x00, 0x00, 0x00, 0x3f, 0xe0, 0, 0, 0, 0, 0, 0}) {
    b.push_back(v);
  }
  PointCloud c;
  std::string error;
  ASSERT_TRUE(parse_ply(b, c, error)) << error;
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c.points[0], Eigen::Vector3f(1.0f, -2.0f, 0.5f));
}

TEST(PlyReader, ClearErrors) {
  PointCloud c;
  std::string error;
  EXPECT_FALSE(parse_ply(bytes_of("plx\n"), c, error));
  EXPECT_NE(error.find("not a PLY"), std::string::npos);
  EXPECT_FALSE(parse_ply(bytes_of("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n"), c, error));
  EXPECT_NE(error.find("x, y and z"), std::string::npos);
  EXPECT_FALSE(parse_ply(bytes_of("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                  "property float y\nproperty float z\nend_header\n1 2 3\n"), c, error));
  EXPECT_NE(error.find("truncated"), std::string::npos) << error;
  EXPECT_FALSE(parse_ply(bytes_of("ply\nformat ascii 1.0\nelement vertex 1\nproperty quaternion x\nend_header\n"), c, error));
  EXPECT_FALSE(parse_ply(bytes_of("ply\nformat ascii 1.0\nelement vertex 1\n"), c, error));
  EXPECT_NE(error.find("end_header"), std::string::npos);
}

}  // namespace
}  // namespace v2xloc::cloud_io
