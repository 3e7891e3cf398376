#include "host_sim/common/png.hpp"

#include <png.h>

#include <bit>
#include <cstdio>
#include <csetjmp>
#include <cstring>
#include <fstream>
#include <iterator>

namespace v2xloc::sim {
namespace {

// libpng reports errors through a callback that must not return: we keep the message and
// longjmp back to the setjmp in the calling function (libpng's documented error model). Every C++
// object with a destructor lives outside the setjmp region, so the jump skips no destructor.
struct ErrorSink {
  char message[256] = "libpng error";
};

void on_error(png_structp png, png_const_charp message) {
  auto* sink = static_cast<ErrorSink*>(png_get_error_ptr(png));
  std::snprintf(sink->message, sizeof sink->message, "%s", message);
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}  // warnings (e.g. unknown ancillary chunks) are harmless

void append_bytes(png_structp png, png_bytep data, png_size_t n) {
  auto* out = static_cast<std::vector<std::uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + n);
}

struct MemoryReader {
  std::span<const std::uint8_t> bytes;
  std::size_t pos = 0;
};

void read_bytes(png_structp png, png_bytep data, png_size_t n) {
  auto* in = static_cast<MemoryReader*>(png_get_io_ptr(png));
  if (n > in->bytes.size() - in->pos) png_error(png, "truncated PNG");
  std::memcpy(data, in->bytes.data() + in->pos, n);
  in->pos += n;
}

// Rows of `bytes_per_row` bytes starting at `data` (no copy).
std::vector<png_bytep> row_pointers(const void* data, int height, std::size_t bytes_per_row) {
  std::vector<png_bytep> rows(static_cast<std::size_t>(height));
  auto* base = static_cast<png_bytep>(const_cast<void*>(data));
  for (std::size_t y = 0; y < rows.size(); ++y) rows[y] = base + y * bytes_per_row;
  return rows;
}

bool encode_gray16(int width, int height, const std::vector<png_bytep>& rows, std::vector<std::uint8_t>& out,
                   std::string& error) {
  ErrorSink sink;
  out.clear();
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &sink, on_error, on_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, nullptr);
    error = "libpng: out of memory";
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    error = std::string("PNG encoding failed: ") + sink.message;
    return false;
  }
  png_set_write_fn(png, &out, append_bytes, nullptr);
  // zlib level 1: a recording writes 200 disparity maps; on them level 6 was 4 % smaller but twice
  // the time (22 vs 11 ms per 621 x 187 map).
  png_set_compression_level(png, 1);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 16, PNG_COLOR_TYPE_GRAY,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  // PNG stores 16-bit samples big-endian; our pixels are in host order.
  if (std::endian::native == std::endian::little) png_set_swap(png);
  png_write_image(png, const_cast<png_bytepp>(rows.data()));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

bool check_size(int width, int height, std::size_t values, std::string& error) {
  if (width <= 0 || height <= 0) {
    error = "cannot encode an empty image";
    return false;
  }
  if (values != static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    error = "image has " + std::to_string(values) + " values, expected " + std::to_string(width) + " x " +
            std::to_string(height);
    return false;
  }
  return true;
}

enum class Want { kGray16, kRgb8 };

// Decodes into `pixels` (resized here): kGray16 accepts only 16-bit grayscale; kRgb8 converts any
// PNG to 8-bit RGB.
bool decode(std::span<const std::uint8_t> bytes, Want want, int& width, int& height, std::vector<std::uint8_t>* rgb,
            std::vector<std::uint16_t>* gray, std::string& error) {
  if (bytes.size() < 8 || png_sig_cmp(bytes.data(), 0, 8) != 0) {
    error = "not a PNG file (bad signature)";
    return false;
  }
  ErrorSink sink;
  MemoryReader reader{bytes, 0};
  std::vector<png_bytep> rows;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &sink, on_error, on_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    error = "libpng: out of memory";
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    error = std::string("PNG decoding failed: ") + sink.message;
    return false;
  }
  png_set_read_fn(png, &reader, read_bytes);
  png_read_info(png, info);
  const int depth = png_get_bit_depth(png, info);
  const int colour = png_get_color_type(png, info);
  if (want == Want::kGray16) {
    if (depth != 16 || colour != PNG_COLOR_TYPE_GRAY) png_error(png, "expected a 16-bit grayscale PNG");
    if (std::endian::native == std::endian::little) png_set_swap(png);
  } else {
    if (colour == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (colour == PNG_COLOR_TYPE_GRAY || colour == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(png);
    if (colour == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (depth == 16) png_set_strip_16(png);
    png_set_strip_alpha(png);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  width = static_cast<int>(png_get_image_width(png, info));
  height = static_cast<int>(png_get_image_height(png, info));
  const std::size_t row_bytes = png_get_rowbytes(png, info);
  void* data = nullptr;
  if (want == Want::kGray16) {
    if (row_bytes != static_cast<std::size_t>(width) * 2) png_error(png, "unexpected row size");
    gray->assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0);
    data = gray->data();
  } else {
    if (row_bytes != static_cast<std::size_t>(width) * 3) png_error(png, "unexpected row size");
    rgb->assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3, 0);
    data = rgb->data();
  }
  rows = row_pointers(data, height, row_bytes);
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

bool read_file(const std::string& path, std::vector<std::uint8_t>& bytes, std::string& error) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    error = "cannot open " + path;
    return false;
  }
  bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  return true;
}

bool write_file(const std::string& path, const std::vector<std::uint8_t>& bytes, std::string& error) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!f) {
    error = "cannot write " + path;
    return false;
  }
  return true;
}

}  // namespace

bool encode_png(const Image16& image, std::vector<std::uint8_t>& out, std::string& error) {
  if (!check_size(image.width, image.height, image.pixels.size(), error)) return false;
  return encode_gray16(image.width, image.height,
                       row_pointers(image.pixels.data(), image.height, static_cast<std::size_t>(image.width) * 2), out,
                       error);
}

bool write_png(const std::string& path, const Image16& image, std::string& error) {
  std::vector<std::uint8_t> bytes;
  if (!encode_png(image, bytes, error)) {
    error = path + ": " + error;
    return false;
  }
  return write_file(path, bytes, error);
}

bool decode_png16(std::span<const std::uint8_t> bytes, Image16& out, std::string& error) {
  return decode(bytes, Want::kGray16, out.width, out.height, nullptr, &out.pixels, error);
}

bool decode_png_rgb(std::span<const std::uint8_t> bytes, ImageRgb& out, std::string& error) {
  return decode(bytes, Want::kRgb8, out.width, out.height, &out.pixels, nullptr, error);
}

bool read_png16(const std::string& path, Image16& out, std::string& error) {
  std::vector<std::uint8_t> bytes;
  if (!read_file(path, bytes, error)) return false;
  if (!decode_png16(bytes, out, error)) {
    error = path + ": " + error;
    return false;
  }
  return true;
}

bool read_png_rgb(const std::string& path, ImageRgb& out, std::string& error) {
  std::vector<std::uint8_t> bytes;
  if (!read_file(path, bytes, error)) return false;
  if (!decode_png_rgb(bytes, out, error)) {
    error = path + ": " + error;
    return false;
  }
  return true;
}

}  // namespace v2xloc::sim
