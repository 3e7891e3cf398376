// PNG through libpng: 16-bit disparity maps written and read, any PNG read as RGB.
#include "host_sim/common/png.hpp"

#include <gtest/gtest.h>

#include <string>

namespace v2xloc::sim {
namespace {

Image16 gradient16(int w, int h) {
  Image16 img;
  img.width = w;
  img.height = h;
  for (int i = 0; i < w * h; ++i) img.pixels.push_back(static_cast<std::uint16_t>(i * 37));
  return img;
}

// A 4 x 2 8-bit RGB PNG, every pixel (200, 100, 50) (IHDR, one zlib IDAT, IEND; built with
// Python's zlib and struct).
const std::vector<std::uint8_t> kRgbPng = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00,
    0x00, 0x04, 0x00, 0x00, 0x00, 0x02, 0x08, 0x02, 0x00, 0x00, 0x00, 0xf0, 0xca, 0xea, 0x34, 0x00, 0x00, 0x00,
    0x10, 0x49, 0x44, 0x41, 0x54, 0x78, 0xda, 0x63, 0x38, 0x91, 0x62, 0x04, 0x47, 0x0c, 0xc8, 0x1c, 0x00, 0x92,
    0xfa, 0x0a, 0xf1, 0xa3, 0x4f, 0x27, 0x4f, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60,
    0x82};

TEST(HostSimPng, Png16RoundTripsEvery16BitValue) {
  Image16 img = gradient16(300, 150);
  img.pixels[0] = 0xFFFF;  // both bytes matter: a byte-order slip would show here
  img.pixels[1] = 0x0102;
  std::vector<std::uint8_t> bytes;
  std::string err;
  ASSERT_TRUE(encode_png(img, bytes, err)) << err;
  Image16 back;
  ASSERT_TRUE(decode_png16(bytes, back, err)) << err;
  EXPECT_EQ(back.width, img.width);
  EXPECT_EQ(back.height, img.height);
  EXPECT_EQ(back.pixels, img.pixels);
  // Compressed, unlike the stored-deflate files this replaced (2 bytes per pixel + framing).
  EXPECT_LT(bytes.size(), img.pixels.size() * 2);
}

TEST(HostSimPng, CorruptTruncatedAndWrongKindAreErrors) {
  std::vector<std::uint8_t> bytes;
  std::string err;
  ASSERT_TRUE(encode_png(gradient16(64, 64), bytes, err)) << err;
  Image16 back;
  auto corrupt = bytes;
  corrupt[corrupt.size() / 2] ^= 0x01;  // inside IDAT: CRC or zlib check fails
  EXPECT_FALSE(decode_png16(corrupt, back, err));
  EXPECT_NE(err.find("PNG"), std::string::npos) << err;
  EXPECT_FALSE(decode_png16(std::span(bytes).first(bytes.size() / 3), back, err));
  EXPECT_FALSE(decode_png16(std::span(bytes).first(4), back, err));
  EXPECT_NE(err.find("signature"), std::string::npos) << err;
  EXPECT_FALSE(decode_png16(kRgbPng, back, err));  // an RGB picture is not a disparity map
  EXPECT_NE(err.find("16-bit grayscale"), std::string::npos) << err;
  Image16 short_of_pixels = gradient16(4, 2);
  short_of_pixels.pixels.pop_back();
  EXPECT_FALSE(encode_png(short_of_pixels, bytes, err));
  EXPECT_NE(err.find("expected 4 x 2"), std::string::npos) << err;
  EXPECT_FALSE(encode_png(Image16{}, bytes, err));
  EXPECT_FALSE(read_png16("/nonexistent/x.png", back, err));
}

TEST(HostSimPng, RgbReaderConvertsAnyPng) {
  std::vector<std::uint8_t> bytes;
  std::string err;
  ASSERT_TRUE(encode_png(gradient16(10, 3), bytes, err)) << err;
  ImageRgb rgb;
  ASSERT_TRUE(decode_png_rgb(bytes, rgb, err)) << err;  // 16-bit gray -> 8-bit RGB
  ASSERT_EQ(rgb.pixels.size(), 10u * 3u * 3u);
  EXPECT_EQ(rgb.pixels[3 * 5], rgb.pixels[3 * 5 + 2]);  // gray: R == B
  EXPECT_EQ(rgb.pixels[3 * 5], (5 * 37) >> 8);         // the high byte survives
  ASSERT_TRUE(decode_png_rgb(kRgbPng, rgb, err)) << err;
  EXPECT_EQ(rgb.width, 4);
  EXPECT_EQ(rgb.height, 2);
  EXPECT_EQ(rgb.pixels, std::vector<std::uint8_t>({200, 100, 50, 200, 100, 50, 200, 100, 50, 200, 100, 50, 200, 100, 50,
                                                   200, 100, 50, 200, 100, 50, 200, 100, 50}));
}

}  // namespace
}  // namespace v2xloc::sim
