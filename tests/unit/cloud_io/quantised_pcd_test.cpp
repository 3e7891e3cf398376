// Quantised clouds (.pcdz, DATA binary_shuffled_zlib + SCALE; recording format 2): values come back
// within half a step, the same cloud gives the same bytes, values that do not fit are refused at
// write time, and hostile headers / blocks are refused with a message at read time.
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace v2xloc::cloud_io {
namespace {

// A LiDAR-like sweep: 32 beams x 256 columns, range 2-80 m with 2 cm noise, firing times in 0.1 s.
PointCloud lidar_like_sweep() {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  PointCloud c;
  for (int col = 0; col < 256; ++col) {
    const double az = -M_PI + 2.0 * M_PI * (col + 0.5) / 256.0;
    for (int beam = 0; beam < 32; ++beam) {
      const double el = (2.0 - 27.0 * beam / 31.0) * M_PI / 180.0;
      const double r = 2.0 + 78.0 * uniform(rng) * uniform(rng) + noise(rng);
      c.points.emplace_back(static_cast<float>(r * std::cos(el) * std::cos(az)),
                            static_cast<float>(r * std::cos(el) * std::sin(az)), static_cast<float>(r * std::sin(el)));
      c.intensity.push_back(static_cast<float>(uniform(rng)));
      c.time.push_back(static_cast<float>(0.1 * col / 256.0));
    }
  }
  c.width = static_cast<std::uint32_t>(c.points.size());
  return c;
}

std::vector<std::uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }

TEST(QuantisedPcd, ValuesComeBackWithinHalfAStep) {
  PointCloud cloud = lidar_like_sweep();
  cloud.width = 256;
  cloud.height = 32;
  cloud.has_viewpoint = true;
  cloud.sensor_origin = Eigen::Vector3f(1.5f, -2.0f, 0.25f);
  const Quantisation q;
  std::vector<std::uint8_t> bytes;
  std::string error;
  ASSERT_TRUE(encode_quantised_pcd(cloud, q, bytes, error)) << error;
  PointCloud back;
  ASSERT_TRUE(parse_pcd(bytes, back, error)) << error;
  ASSERT_EQ(back.size(), cloud.size());
  EXPECT_EQ(back.width, 256u);
  EXPECT_EQ(back.height, 32u);
  EXPECT_EQ(back.sensor_origin, cloud.sensor_origin);
  ASSERT_TRUE(back.has_intensity() && back.has_time());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    for (int k = 0; k < 3; ++k) ASSERT_LE(std::abs(back.points[i][k] - cloud.points[i][k]), 0.5e-3f + 1e-5f) << i;
    ASSERT_LE(std::abs(back.intensity[i] - cloud.intensity[i]), 0.5f / 255.0f + 1e-6f) << i;
    ASSERT_LE(std::abs(back.time[i] - cloud.time[i]), 1e-9f) << i;
  }
  // The steps stay far below the simulated noise: 2 cm range noise is 20 steps of 1 mm.
  EXPECT_LE(q.xyz_step_m * 5.0, 0.02);
}

// (Random ranges compress worse than a real scene: a simulated recording shrinks 3.6x.)
TEST(QuantisedPcd, SameCloudSameBytesAndLessThanHalfOfBinaryCompressed) {
  const PointCloud cloud = lidar_like_sweep();
  std::vector<std::uint8_t> a, b, lzf;
  std::string error;
  ASSERT_TRUE(encode_quantised_pcd(cloud, {}, a, error)) << error;
  ASSERT_TRUE(encode_quantised_pcd(cloud, {}, b, error)) << error;
  EXPECT_EQ(a, b);
  ASSERT_TRUE(encode_pcd(cloud, PcdEncoding::kBinaryCompressed, lzf, error)) << error;
  EXPECT_LT(a.size() * 2, lzf.size()) << a.size() << " vs " << lzf.size();
}

TEST(QuantisedPcd, ValuesThatDoNotFitAreRefusedAtWriteTime) {
  std::vector<std::uint8_t> bytes;
  std::string error;
  auto refused = [&](PointCloud c, const std::string& what) {
    error.clear();
    EXPECT_FALSE(encode_quantised_pcd(c, {}, bytes, error)) << what;
    EXPECT_NE(error.find(what), std::string::npos) << error;
  };
  PointCloud base;
  base.points = {{0, 0, 0}, {1, 2, 3}};
  base.intensity = {0.0f, 1.0f};
  base.time = {0.0f, 0.05f};
  ASSERT_TRUE(encode_quantised_pcd(base, {}, bytes, error)) << error;
  PointCloud c = base;
  c.points[1].x() = NAN;
  refused(c, "point 1: x");
  c = base;
  c.points[1].z() = 3e6f;  // 3000 km: beyond int32 millimetres
  refused(c, "point 1: z");
  c = base;
  c.intensity[0] = 1.5f;
  refused(c, "point 0: intensity");
  c.intensity[0] = -0.1f;
  refused(c, "point 0: intensity");
  c = base;
  c.time[1] = -1e-3f;
  refused(c, "point 1: t");
  c.time[1] = 5.0f;  // beyond uint32 nanoseconds
  refused(c, "point 1: t");
  c = base;
  c.normals = {{0, 0, 1}, {0, 0, 1}};
  refused(c, "no normals");
  Quantisation zero;
  zero.xyz_step_m = 0.0;
  EXPECT_FALSE(encode_quantised_pcd(base, zero, bytes, error));
}

// The header of a valid 2-point file with x y z only, and its data block.
struct Parts {
  std::string header_before_data;
  std::vector<std::uint8_t> data;  // after "DATA binary_shuffled_zlib\n"
};

Parts parts_of_small_file() {
  PointCloud c;
  c.points = {{1, 2, 3}, {4, 5, 6}};
  std::vector<std::uint8_t> bytes;
  std::string error;
  EXPECT_TRUE(encode_quantised_pcd(c, {}, bytes, error)) << error;
  const std::string text(bytes.begin(), bytes.end());
  const std::string marker = "DATA binary_shuffled_zlib\n";
  const std::size_t at = text.find(marker);
  Parts p;
  p.header_before_data = text.substr(0, at);
  p.data.assign(bytes.begin() + static_cast<std::ptrdiff_t>(at + marker.size()), bytes.end());
  return p;
}

std::string refusal(const std::vector<std::uint8_t>& bytes) {
  PointCloud c;
  std::string error;
  if (parse_pcd(bytes, c, error)) return "";
  EXPECT_TRUE(c.empty());
  return error;
}

TEST(QuantisedPcd, HostileHeadersAndBlocksAreRefused) {
  const Parts p = parts_of_small_file();
  auto file = [&](const std::string& header, const std::string& data_kind, std::vector<std::uint8_t> data) {
    std::vector<std::uint8_t> b = bytes_of(header + "DATA " + data_kind + "\n");
    b.insert(b.end(), data.begin(), data.end());
    return b;
  };
  ASSERT_EQ(refusal(file(p.header_before_data, "binary_shuffled_zlib", p.data)), "");

  // SCALE belongs to this data kind only: PCL would read a standard file's values unscaled.
  std::string h = p.header_before_data;
  EXPECT_NE(refusal(file(h, "binary", std::vector<std::uint8_t>(24, 0))).find("SCALE is only defined"), std::string::npos);
  const std::size_t scale = h.find("\nSCALE") + 1;  // the comment line names SCALE too
  const std::size_t eol = h.find('\n', scale);
  for (const char* bad : {"SCALE 0.001 0.001", "SCALE 0 0.001 0.001", "SCALE -1 1 1", "SCALE nan 1 1", "SCALE inf 1 1",
                          "SCALE a b c"}) {
    std::string hb = h;
    hb.replace(scale, eol - scale, bad);
    const std::string err = refusal(file(hb, "binary_shuffled_zlib", p.data));
    EXPECT_NE(err.find("SCALE"), std::string::npos) << bad << ": " << err;
  }
  // Sizes: block larger than the file, raw size that is not POINTS x record, impossible ratio.
  auto with_sizes = [&](std::uint32_t compressed, std::uint32_t raw) {
    std::vector<std::uint8_t> d = p.data;
    std::memcpy(d.data(), &compressed, 4);
    std::memcpy(d.data() + 4, &raw, 4);
    return file(h, "binary_shuffled_zlib", d);
  };
  std::uint32_t compressed = 0, raw = 0;
  std::memcpy(&compressed, p.data.data(), 4);
  std::memcpy(&raw, p.data.data() + 4, 4);
  ASSERT_EQ(raw, 24u);
  EXPECT_NE(refusal(with_sizes(compressed + 1, raw)).find("truncated"), std::string::npos);
  EXPECT_NE(refusal(with_sizes(compressed, raw + 4)).find("raw size"), std::string::npos);
  EXPECT_NE(refusal(with_sizes(compressed - 1, raw)).find("corrupt zlib"), std::string::npos);
  // A valid stream followed by bytes the block claims: not silently ignored.
  {
    std::vector<std::uint8_t> d = p.data;
    d.push_back(0);
    const std::uint32_t longer = compressed + 1;
    std::memcpy(d.data(), &longer, 4);
    EXPECT_NE(refusal(file(h, "binary_shuffled_zlib", d)).find("corrupt zlib"), std::string::npos);
  }
  // POINTS lying upwards with a tiny block: refused before the allocation.
  {
    std::string hb = h;
    hb.replace(hb.find("POINTS 2"), 8, "POINTS 2000000");
    hb.replace(hb.find("WIDTH 2"), 7, "WIDTH 2000000");
    std::vector<std::uint8_t> d = p.data;
    const std::uint32_t big = 2000000u * 12u;
    std::memcpy(d.data() + 4, &big, 4);
    EXPECT_NE(refusal(file(hb, "binary_shuffled_zlib", d)).find("impossible"), std::string::npos);
  }
  // Every flipped byte of the block: refused, or (a flip the checksum cannot see) two points.
  for (std::size_t at = 8; at < p.data.size(); ++at) {
    std::vector<std::uint8_t> d = p.data;
    d[at] ^= 0x41;
    PointCloud c;
    std::string error;
    if (parse_pcd(file(h, "binary_shuffled_zlib", d), c, error)) EXPECT_EQ(c.size(), 2u);
    else EXPECT_FALSE(error.empty());
  }
}

TEST(QuantisedPcd, WriteCloudAndReadCloudUseTheExtension) {
  const std::string path = testing::TempDir() + "/v2xloc_quantised.pcdz";
  const PointCloud cloud = lidar_like_sweep();
  std::string error;
  ASSERT_TRUE(write_cloud(path, cloud, error)) << error;
  PointCloud back;
  ASSERT_TRUE(read_cloud(path, back, error)) << error;
  std::remove(path.c_str());
  EXPECT_EQ(back.size(), cloud.size());
}

}  // namespace
}  // namespace v2xloc::cloud_io
