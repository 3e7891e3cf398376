// PNG files through libpng (the field's PNG library): 16-bit grayscale (KITTI-style disparity maps
// in recordings) written and read, and any PNG read as 8-bit RGB (checking pictures other tools
// draw). Any PNG decoder reads what we write; the readers accept any valid PNG of the right kind,
// whatever compression or filters the writer chose.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace v2xloc::sim {

struct Image16 {  // single channel, 16 bit (e.g. KITTI-style disparity * 256)
  int width = 0;
  int height = 0;
  std::vector<std::uint16_t> pixels;  // row-major
};

struct ImageRgb {  // 8-bit RGB
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> pixels;  // row-major, 3 bytes per pixel
};

// The encoder returns false with `error` set when the image is empty or inconsistent (pixel count
// != width * height) or libpng fails.
bool encode_png(const Image16& image, std::vector<std::uint8_t>& out, std::string& error);
bool write_png(const std::string& path, const Image16& image, std::string& error);

// A 16-bit grayscale PNG (anything else is an error: a disparity map must keep its 16 bits).
bool decode_png16(std::span<const std::uint8_t> bytes, Image16& out, std::string& error);
bool read_png16(const std::string& path, Image16& out, std::string& error);

// Any PNG (gray, palette, RGB, with or without alpha, 8 or 16 bit) converted to 8-bit RGB; alpha is
// dropped. For checking written pictures (tests, tools).
bool decode_png_rgb(std::span<const std::uint8_t> bytes, ImageRgb& out, std::string& error);
bool read_png_rgb(const std::string& path, ImageRgb& out, std::string& error);

}  // namespace v2xloc::sim
