#include "host_sim/common/text_file.hpp"
#include "host_sim/common/png.hpp"
#include "host_sim/common/rng.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include <unistd.h>

namespace v2xloc::sim {
namespace {

std::span<const std::uint8_t> bytes_of(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

TEST(HostSimCommon, Crc32AndAdler32MatchReferenceValues) {
  EXPECT_EQ(crc32(bytes_of("123456789")), 0xCBF43926u);  // the standard CRC-32 check value
  EXPECT_EQ(adler32(bytes_of("Wikipedia")), 0x11E60398u);  // RFC 1950 example value
}

TEST(HostSimCommon, Png16RoundTripsThroughStoredDeflate) {
  Image16 img;
  img.width = 300;  // > 65535 bytes of rows -> several stored blocks
  img.height = 150;
  for (int i = 0; i < img.width * img.height; ++i) img.pixels.push_back(static_cast<std::uint16_t>(i * 37));
  const auto bytes = encode_png(img);
  Image16 back;
  std::string err;
  ASSERT_TRUE(decode_png16(bytes, back, err)) << err;
  EXPECT_EQ(back.width, img.width);
  EXPECT_EQ(back.height, img.height);
  EXPECT_EQ(back.pixels, img.pixels);
  auto corrupt = bytes;
  corrupt[60] ^= 0x01;  // inside IDAT -> CRC mismatch
  EXPECT_FALSE(decode_png16(corrupt, back, err));
}

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
