// Writers: PCL's exact header, lossless round trips through every format, LZF round trips.
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

namespace v2xloc::cloud_io {
namespace {

void expect_same(const PointCloud& a, const PointCloud& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.intensity, b.intensity);
  EXPECT_EQ(a.time, b.time);
  ASSERT_EQ(a.normals.size(), b.normals.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    // Bit-exact, NaN included.
    ASSERT_EQ(std::memcmp(a.points[i].data(), b.points[i].data(), 12), 0) << "point " << i;
    if (a.has_normals()) {
      ASSERT_EQ(a.normals[i], b.normals[i]) << "normal " << i;
    }
  }
}

std::string header_of(const std::vector<std::uint8_t>& bytes) {
  const std::string s(bytes.begin(), bytes.end());
  const std::size_t data = s.find("DATA ");
  return s.substr(0, s.find('\n', data) + 1);
}

TEST(PcdWriter, HeaderIsExactlyWhatPclWrites) {
  PointCloud c = test::make_cloud(3, true, true, true);
  std::vector<std::uint8_t> bytes;
  std::string error;
  ASSERT_TRUE(encode_pcd(c, PcdEncoding::kBinary, bytes, error)) << error;
  EXPECT_EQ(header_of(bytes),
            "# .PCD v0.7 - Point Cloud Data file format\n"
            "VERSION 0.7\n"
            "FIELDS x y z intensity t normal_x normal_y normal_z\n"
            "SIZE 4 4 4 4 4 4 4 4\n"
            "TYPE F F F F F F F F\n"
            "COUNT 1 1 1 1 1 1 1 1\n"
            "WIDTH 3\n"
            "HEIGHT 1\n"
            "VIEWPOINT 0 0 0 1 0 0 0\n"
            "POINTS 3\n"
            "DATA binary\n");
  EXPECT_EQ(bytes.size(), header_of(bytes).size() + 3 * 8 * 4);

  ASSERT_TRUE(encode_pcd(test::make_cloud(2, false, false, false), PcdEncoding::kAscii, bytes, error));
  const std::string text(bytes.begin(), bytes.end());
  EXPECT_NE(text.find("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\n"), std::string::npos);
  EXPECT_NE(text.find("DATA ascii\n-3 1 -0\n-2.9 0.5 -0.0025\n"), std::string::npos) << text;
}

TEST(PcdWriter, OrganizedCloudAndViewpointSurvive) {
  PointCloud c = test::make_cloud(6, false, true, false);
  c.width = 3;
  c.height = 2;
  c.has_viewpoint = true;
  c.sensor_origin = Eigen::Vector3f(1.5f, -2.0f, 5.25f);
  c.sensor_orientation = Eigen::Quaternionf(0.5f, 0.5f, -0.5f, 0.5f);
  for (PcdEncoding enc : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    std::vector<std::uint8_t> bytes;
    std::string error;
    ASSERT_TRUE(encode_pcd(c, enc, bytes, error)) << error;
    PointCloud r;
    ASSERT_TRUE(parse_pcd(bytes, r, error)) << error;
    expect_same(c, r);
    EXPECT_EQ(r.width, 3u);
    EXPECT_EQ(r.height, 2u);
    EXPECT_EQ(r.sensor_origin, c.sensor_origin);
    EXPECT_EQ(r.sensor_orientation.coeffs(), c.sensor_orientation.coeffs());
  }
}

TEST(RoundTrip, EveryFormatEveryAttributeCombination) {
  for (int mask = 0; mask < 8; ++mask) {
    PointCloud c = test::make_cloud(50, mask & 1, mask & 2, mask & 4);
    c.points[7] = Eigen::Vector3f(std::nanf(""), 1.0f, 2.0f);
    c.points[8] = Eigen::Vector3f(INFINITY, -INFINITY, 1e-38f);
    c.points[9] = Eigen::Vector3f(3.4e38f, -1.17549435e-38f, 1.4e-45f);
    std::vector<std::uint8_t> bytes;
    std::string error;
    PointCloud r;
    for (PcdEncoding enc : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
      SCOPED_TRACE(testing::Message() << "mask " << mask << " pcd " << static_cast<int>(enc));
      ASSERT_TRUE(encode_pcd(c, enc, bytes, error)) << error;
      ReadStats stats;
      ASSERT_TRUE(parse_pcd(bytes, r, error, {}, &stats)) << error;
      expect_same(c, r);
      EXPECT_EQ(stats.non_finite, 2u);
    }
    SCOPED_TRACE(testing::Message() << "mask " << mask);
    ASSERT_TRUE(encode_ply(c, bytes, error)) << error;
    ASSERT_TRUE(parse_ply(bytes, r, error)) << error;
    expect_same(c, r);
    ASSERT_TRUE(encode_kitti_bin(c, bytes, error)) << error;
    ASSERT_TRUE(parse_kitti_bin(bytes, r, error)) << error;
    ASSERT_EQ(r.size(), c.size());
    for (std::size_t i = 0; i < c.size(); ++i) {
      ASSERT_EQ(std::memcmp(c.points[i].data(), r.points[i].data(), 12), 0);
      EXPECT_EQ(r.intensity[i], c.has_intensity() ? c.intensity[i] : 0.0f);
    }
  }
}

TEST(RoundTrip, DropNonFiniteRemovesPointsWithTheirAttributes) {
  PointCloud c = test::make_cloud(5, true, true, true);
  c.points[1].y() = std::nanf("");
  c.points[3].z() = INFINITY;
  std::vector<std::uint8_t> bytes;
  std::string error;
  ASSERT_TRUE(encode_pcd(c, PcdEncoding::kBinary, bytes, error));
  PointCloud r;
  ReadStats stats;
  ReadOptions options;
  options.drop_non_finite = true;
  ASSERT_TRUE(parse_pcd(bytes, r, error, options, &stats)) << error;
  EXPECT_EQ(stats.non_finite, 2u);
  EXPECT_EQ(stats.dropped, 2u);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r.points[1], c.points[2]);
  EXPECT_EQ(r.intensity[2], c.intensity[4]);
  EXPECT_EQ(r.time[1], c.time[2]);
  EXPECT_EQ(r.normals[2], c.normals[4]);
}

TEST(RoundTrip, FilesOnDiskChosenByExtension) {
  const PointCloud c = test::make_cloud(20, true, false, false);
  const std::string dir = testing::TempDir();
  for (const char* name : {"rt.pcd", "rt.PLY", "rt.bin"}) {
    const std::string path = dir + "/" + name;
    std::string error;
    ASSERT_TRUE(write_cloud(path, c, error)) << error;
    PointCloud r;
    ASSERT_TRUE(read_cloud(path, r, error)) << error;
    expect_same(c, r);
    std::remove(path.c_str());
  }
  std::string error;
  PointCloud r;
  EXPECT_FALSE(read_cloud(dir + "/x.xyz", r, error));
  EXPECT_NE(error.find("extension"), std::string::npos);
  EXPECT_FALSE(read_cloud(dir + "/does_not_exist.pcd", r, error));
  EXPECT_NE(error.find("cannot open"), std::string::npos);
}

TEST(Writers, RejectInconsistentClouds) {
  PointCloud c = test::make_cloud(4, true, false, false);
  c.intensity.pop_back();
  std::vector<std::uint8_t> bytes;
  std::string error;
  EXPECT_FALSE(encode_pcd(c, PcdEncoding::kAscii, bytes, error));
  EXPECT_FALSE(encode_ply(c, bytes, error));
  EXPECT_FALSE(encode_kitti_bin(c, bytes, error));
}

TEST(Lzf, RoundTripsRandomAndRepetitiveData) {
  std::mt19937 rng(42);
  for (std::size_t size : {0u, 1u, 2u, 3u, 31u, 32u, 33u, 1000u, 70000u}) {
    for (int kind = 0; kind < 3; ++kind) {
      std::vector<std::uint8_t> in(size);
      for (std::size_t i = 0; i < size; ++i) {
        in[i] = kind == 0 ? static_cast<std::uint8_t>(rng())
              : kind == 1 ? static_cast<std::uint8_t>(i % 7 == 0 ? rng() % 3 : 0)
                          : static_cast<std::uint8_t>((i / 300) & 0xff);
      }
      std::vector<std::uint8_t> packed;
      ASSERT_TRUE(lzf_compress(in, packed));
      std::vector<std::uint8_t> out(size);
      EXPECT_EQ(lzf_decompress(packed, out), size) << size << " " << kind;
      EXPECT_EQ(in, out);
      if (kind == 2 && size >= 1000) {
        EXPECT_LT(packed.size(), size / 10);
      }
    }
  }
}

TEST(Lzf, RejectsCorruptStreams) {
  std::vector<std::uint8_t> out(16);
  const std::vector<std::uint8_t> back_ref_before_start = {0x20, 0x05};
  EXPECT_EQ(lzf_decompress(back_ref_before_start, out), 0u);
  const std::vector<std::uint8_t> literal_past_end = {0x05, 1, 2};
  EXPECT_EQ(lzf_decompress(literal_past_end, out), 0u);
  const std::vector<std::uint8_t> output_overflow = {0x00, 7, 0xe0, 0xff, 0x00};
  EXPECT_EQ(lzf_decompress(output_overflow, out), 0u);
  const std::vector<std::uint8_t> missing_offset = {0x00, 7, 0x20};
  EXPECT_EQ(lzf_decompress(missing_offset, out), 0u);
  const std::vector<std::uint8_t> run = {0x00, 7, 0x40, 0x00};  // 1 literal + 4 copies of it
  EXPECT_EQ(lzf_decompress(run, out), 5u);
  EXPECT_EQ(out[4], 7);
}

}  // namespace
}  // namespace v2xloc::cloud_io
