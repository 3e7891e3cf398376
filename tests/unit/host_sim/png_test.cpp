// PNG through libpng (16-bit disparity maps, RGB pictures) and the raster's bitmap text.
#include "host_sim/common/bitmap_font.hpp"
#include "host_sim/common/png.hpp"
#include "host_sim/common/raster.hpp"

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
  ImageRgb rgb;
  rgb.width = 4;
  rgb.height = 2;
  rgb.pixels.assign(4 * 2 * 3, 200);
  ASSERT_TRUE(encode_png(rgb, bytes, err)) << err;
  EXPECT_FALSE(decode_png16(bytes, back, err));  // an RGB picture is not a disparity map
  EXPECT_NE(err.find("16-bit grayscale"), std::string::npos) << err;
  rgb.pixels.pop_back();
  EXPECT_FALSE(encode_png(rgb, bytes, err));
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
}

TEST(HostSimRaster, BitmapTextDrawsInkWhereTheGlyphsAre) {
  EXPECT_EQ(glyph('a'), glyph('A'));  // lower case drawn as capitals
  EXPECT_EQ(glyph('\x01'), glyph('?'));
  EXPECT_NE(glyph('0'), glyph('O'));
  Canvas c(0, 0, 100, 20, 1.0, Rgb{255, 255, 255});
  c.text_px(2, 2, "ego 20 m", Rgb{0, 0, 0}, 2);
  EXPECT_EQ(Canvas::text_width_px("ego 20 m", 2), 8 * 12 - 2);
  int ink = 0;
  for (int y = 0; y < c.image().height; ++y)
    for (int x = 0; x < c.image().width; ++x) {
      const bool black = c.image().pixels[static_cast<std::size_t>((y * c.image().width + x) * 3)] == 0;
      ink += black ? 1 : 0;
      // Nothing outside the text's box.
      if (black) {
        EXPECT_GE(x, 2);
        EXPECT_LT(x, 2 + Canvas::text_width_px("ego 20 m", 2));
        EXPECT_GE(y, 2);
        EXPECT_LT(y, 2 + Canvas::text_height_px(2));
      }
    }
  EXPECT_GT(ink, 100);
}

}  // namespace
}  // namespace v2xloc::sim
