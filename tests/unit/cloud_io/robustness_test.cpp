// Malformed input never crashes and never returns garbage: every truncation of a small file,
// headers that lie, absurd counts, seeded random header garbage and random byte flips.
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <random>

namespace v2xloc::cloud_io {
namespace {

std::vector<std::uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }

using Parser = bool (*)(std::span<const std::uint8_t>, PointCloud&, std::string&, const ReadOptions&,
                        ReadStats*);

// Every strict prefix must fail with a message, or (ascii/PLY whose cut falls on the last value's
// digits) succeed with exactly the full point count and finite values.
void check_every_truncation(const std::vector<std::uint8_t>& full, Parser parse, std::size_t n) {
  PointCloud c;
  std::string error;
  ASSERT_TRUE(parse(full, c, error, {}, nullptr)) << error;
  ASSERT_EQ(c.size(), n);
  for (std::size_t len = 0; len < full.size(); ++len) {
    error.clear();
    const bool ok = parse(std::span<const std::uint8_t>(full.data(), len), c, error, {}, nullptr);
    if (ok) {
      ASSERT_EQ(c.size(), n) << "prefix " << len;
    } else {
      ASSERT_FALSE(error.empty()) << "prefix " << len;
      ASSERT_TRUE(c.empty()) << "prefix " << len;
    }
  }
}

TEST(Robustness, EveryTruncationOfEveryFormat) {
  const PointCloud cloud = test::make_cloud(12, true, true, true);
  std::vector<std::uint8_t> bytes;
  std::string error;
  for (PcdEncoding enc : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    SCOPED_TRACE(static_cast<int>(enc));
    ASSERT_TRUE(encode_pcd(cloud, enc, bytes, error));
    check_every_truncation(bytes, parse_pcd, cloud.size());
  }
  {
    SCOPED_TRACE("binary_shuffled_zlib");
    PointCloud q = test::make_cloud(12, false, true, false);
    for (std::size_t i = 0; i < q.size(); ++i) q.intensity.push_back(static_cast<float>(i) / 12.0f);
    ASSERT_TRUE(encode_quantised_pcd(q, {}, bytes, error)) << error;
    check_every_truncation(bytes, parse_pcd, q.size());
  }
  ASSERT_TRUE(encode_ply(cloud, bytes, error));
  check_every_truncation(bytes, parse_ply, cloud.size());
  // KITTI: only whole records are valid; a partial record is an error.
  ASSERT_TRUE(encode_kitti_bin(cloud, bytes, error));
  PointCloud c;
  for (std::size_t len = 0; len < bytes.size(); ++len) {
    const bool ok = parse_kitti_bin(std::span<const std::uint8_t>(bytes.data(), len), c, error);
    ASSERT_EQ(ok, len % 16 == 0) << len;
    if (ok) {
      ASSERT_EQ(c.size(), len / 16);
    }
  }
}

TEST(Robustness, OpenD3FixturesTruncatedEverywhere) {
  for (const char* name : {"xyzni_binary_compressed.pcd", "xyzn_rgb_legacy_binary.pcd"}) {
    std::vector<std::uint8_t> bytes;
    std::string error;
    ASSERT_TRUE(read_file_bytes(test::fixture(name), bytes, error)) << error;
    check_every_truncation(bytes, parse_pcd, 240);
  }
}

TEST(Robustness, LyingHeadersGiveClearErrors) {
  const std::string head =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1000\nHEIGHT 1\n";
  PointCloud c;
  std::string error;
  EXPECT_FALSE(parse_pcd(bytes_of(head + "POINTS 1000\nDATA binary\n" + std::string(24, '\0')), c, error));
  EXPECT_NE(error.find("truncated"), std::string::npos) << error;
  EXPECT_FALSE(parse_pcd(bytes_of(head + "POINTS 1000\nDATA ascii\n1 2 3\n4 5 6\n"), c, error));
  EXPECT_NE(error.find("truncated"), std::string::npos) << error;
  EXPECT_FALSE(parse_pcd(bytes_of(head + "POINTS 18446744073709551615\nDATA binary\n"), c, error));
  EXPECT_NE(error.find("exceeds"), std::string::npos) << error;
  EXPECT_FALSE(parse_pcd(bytes_of(head + "POINTS 1000\nDATA ascii\n1 2\n"), c, error));
  EXPECT_NE(error.find("values"), std::string::npos) << error;
  EXPECT_FALSE(parse_pcd(bytes_of(head + "POINTS 1\nDATA ascii\n1 2 banana\n"), c, error));
  EXPECT_NE(error.find("bad number"), std::string::npos) << error;
  // Compressed: raw size claiming far more than LZF can expand to is rejected before allocating.
  std::string compressed = head + "POINTS 1000\nDATA binary_compressed\n";
  std::vector<std::uint8_t> b = bytes_of(compressed);
  for (std::uint8_t v : {4, 0, 0, 0, 0xe0, 0x2e, 0, 0, 0, 1, 2, 3}) b.push_back(v);  // raw 12000
  EXPECT_FALSE(parse_pcd(b, c, error));
  EXPECT_NE(error.find("impossible"), std::string::npos) << error;
  // Huge COUNT / SIZE / WIDTH x HEIGHT overflow / unsupported types.
  EXPECT_FALSE(parse_pcd(bytes_of("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 4000000000\n"
                                  "WIDTH 1\nPOINTS 1\nDATA binary\n"), c, error));
  EXPECT_FALSE(parse_pcd(bytes_of("FIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nWIDTH 1\nDATA binary\n"), c, error));
  EXPECT_FALSE(parse_pcd(bytes_of("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4294967296\n"
                                  "HEIGHT 4294967296\nDATA binary\n"), c, error));
  EXPECT_FALSE(parse_pcd(bytes_of("FIELDS x y\nSIZE 4 4\nTYPE F F\nWIDTH 1\nDATA ascii\n1 2\n"), c, error));
  EXPECT_NE(error.find("x, y and z"), std::string::npos);
  EXPECT_FALSE(parse_pcd(bytes_of("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA jpeg\n"), c, error));
  EXPECT_FALSE(parse_pcd(bytes_of(""), c, error));
  EXPECT_NE(error.find("DATA"), std::string::npos);
  // PLY and KITTI equivalents.
  EXPECT_FALSE(parse_ply(bytes_of("ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n"
                                  "property float x\nproperty float y\nproperty float z\nend_header\n"), c, error));
  EXPECT_FALSE(parse_kitti_bin(std::vector<std::uint8_t>(17), c, error));
  EXPECT_NE(error.find("multiple of 16"), std::string::npos);
}

TEST(Robustness, PlyElementCountsCannotStallTheReader) {
  // An element with no properties and 2^64 - 1 instances before "vertex" spun for ever; one with
  // a property and 1e10 instances took 8 s to fail. Both must answer at once.
  const std::string vertex = "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  PointCloud c;
  std::string error;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::uint8_t> b = bytes_of("ply\nformat binary_little_endian 1.0\nelement junk 18446744073709551615\n" + vertex);
  b.resize(b.size() + 12, 0);
  ASSERT_TRUE(parse_ply(b, c, error)) << error;  // property-less instances occupy no bytes
  EXPECT_EQ(c.size(), 1u);
  EXPECT_FALSE(parse_ply(bytes_of("ply\nformat binary_little_endian 1.0\nelement junk 10000000000\nproperty uchar a\n" +
                                  vertex + std::string(13, '\0')), c, error));
  EXPECT_NE(error.find("more instances than the data can hold"), std::string::npos) << error;
  EXPECT_FALSE(parse_ply(bytes_of("ply\nformat ascii 1.0\nelement junk 10000000000\nproperty uchar a\n" + vertex +
                                  "1 2 3\n"), c, error));
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
}

TEST(Robustness, PcdViewpointMustBeAFiniteUnitPose) {
  // VIEWPOINT inf used to read as status ok with a sensor pose 0.56 m off.
  const std::string head = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n";
  const std::string tail = "POINTS 1\nDATA ascii\n1 2 3\n";
  PointCloud c;
  std::string error;
  for (const char* vp : {"inf 0 0 1 0 0 0", "0 0 0 nan 0 0 0", "0 0 0 2 0 0 0", "0 0 0 0 0 0 0", "1e39 0 0 1 0 0 0"}) {
    EXPECT_FALSE(parse_pcd(bytes_of(head + "VIEWPOINT " + vp + "\n" + tail), c, error)) << vp;
    EXPECT_NE(error.find("VIEWPOINT"), std::string::npos) << vp << ": " << error;
  }
  ASSERT_TRUE(parse_pcd(bytes_of(head + "VIEWPOINT 1 2 3 0.707107 0 0 0.707107\n" + tail), c, error)) << error;
  EXPECT_TRUE(c.has_viewpoint);
  EXPECT_FLOAT_EQ(c.sensor_origin.y(), 2.0f);
}

TEST(Robustness, PaddingAndUnknownFieldsAreSkipped) {
  // PCL-style padding field "_" and an integer ring field between the coordinates.
  std::string text = "# .PCD v0.7\nVERSION 0.7\nFIELDS x _ y ring z intensity\nSIZE 8 1 4 2 4 1\n"
                     "TYPE F U F U F U\nCOUNT 1 3 1 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 1 2 3 1 0 0 0\n"
                     "POINTS 2\nDATA binary\n";
  std::vector<std::uint8_t> b = bytes_of(text);
  auto put = [&](auto v) {
    std::uint8_t raw[sizeof(v)];
    std::memcpy(raw, &v, sizeof(v));
    b.insert(b.end(), raw, raw + sizeof(v));
  };
  for (int i = 0; i < 2; ++i) {
    put(1.25 + i); put(std::uint8_t{9}); put(std::uint8_t{9}); put(std::uint8_t{9});
    put(-2.0f * static_cast<float>(i)); put(std::uint16_t{5}); put(0.5f); put(std::uint8_t(200 + i));
  }
  PointCloud c;
  std::string error;
  ReadStats stats;
  ASSERT_TRUE(parse_pcd(b, c, error, {}, &stats)) << error;
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[1], Eigen::Vector3f(2.25f, -2.0f, 0.5f));
  EXPECT_EQ(c.intensity, (std::vector<float>{200.0f, 201.0f}));
  EXPECT_EQ(c.sensor_origin, Eigen::Vector3f(1, 2, 3));
  EXPECT_EQ(stats.skipped_fields, std::vector<std::string>{"ring"});
}

TEST(Robustness, RandomHeaderGarbageAndByteFlips) {
  std::mt19937 rng(1234);
  const PointCloud cloud = test::make_cloud(8, true, false, true);
  std::vector<std::uint8_t> pristine[5];
  std::string error;
  ASSERT_TRUE(encode_pcd(cloud, PcdEncoding::kAscii, pristine[0], error));
  ASSERT_TRUE(encode_pcd(cloud, PcdEncoding::kBinary, pristine[1], error));
  ASSERT_TRUE(encode_pcd(cloud, PcdEncoding::kBinaryCompressed, pristine[2], error));
  ASSERT_TRUE(encode_ply(cloud, pristine[3], error));
  PointCloud quantisable = cloud;
  quantisable.normals.clear();
  quantisable.intensity.assign(cloud.size(), 0.25f);
  ASSERT_TRUE(encode_quantised_pcd(quantisable, {}, pristine[4], error)) << error;
  const char alphabet[] = "0123456789 -.\nFIELDSxyzWIDTHPOINTSDATAbinary_compressedasciielementvertexSCALE_shuffled_zlib";
  PointCloud c;
  std::size_t accepted = 0;
  for (int iter = 0; iter < 3000; ++iter) {
    std::vector<std::uint8_t> b = pristine[iter % 5];
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      // Mostly the header (first ~250 bytes), sometimes anywhere.
      const std::size_t limit = (rng() % 4 == 0) ? b.size() : std::min<std::size_t>(b.size(), 250);
      const std::size_t at = rng() % limit;
      switch (rng() % 3) {
        case 0: b[at] = static_cast<std::uint8_t>(rng()); break;
        case 1: b[at] = static_cast<std::uint8_t>(alphabet[rng() % (sizeof(alphabet) - 1)]); break;
        default: b.erase(b.begin() + static_cast<std::ptrdiff_t>(at)); break;
      }
    }
    const bool ok = (iter % 5 == 3) ? parse_ply(b, c, error) : parse_pcd(b, c, error);
    if (ok) {
      ++accepted;
      ASSERT_TRUE(c.consistent());
      ASSERT_LE(c.size(), 100000u);
    } else {
      ASSERT_FALSE(error.empty());
    }
  }
  // Some edits hit only values (still valid files), most break the header.
  EXPECT_GT(accepted, 0u);
  EXPECT_LT(accepted, 3000u);
}

}  // namespace
}  // namespace v2xloc::cloud_io
