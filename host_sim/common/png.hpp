// Minimal PNG (ISO/IEC 15948) writer and reader without zlib: the IDAT stream uses stored
// (uncompressed) deflate blocks (RFC 1951 sec. 3.2.4) inside a zlib wrapper (RFC 1950, Adler-32),
// chunks carry CRC-32 (ISO 3309). Any PNG decoder reads these files; our reader only accepts
// stored-deflate streams (the files we write), which is all the recording reader needs.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace v2xloc::sim {

std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);
std::uint32_t adler32(std::span<const std::uint8_t> bytes, std::uint32_t adler = 1);

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

std::vector<std::uint8_t> encode_png(const Image16& image);
std::vector<std::uint8_t> encode_png(const ImageRgb& image);
bool write_png(const std::string& path, const Image16& image, std::string& error);
bool write_png(const std::string& path, const ImageRgb& image, std::string& error);

// Reads a 16-bit grayscale PNG with stored-deflate IDAT and filter type 0 (what we write).
bool decode_png16(std::span<const std::uint8_t> bytes, Image16& out, std::string& error);
bool read_png16(const std::string& path, Image16& out, std::string& error);

}  // namespace v2xloc::sim
