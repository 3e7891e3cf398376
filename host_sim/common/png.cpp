#include "host_sim/common/png.hpp"

#include <array>
#include <fstream>
#include <iterator>

namespace v2xloc::sim {
namespace {

const std::array<std::uint32_t, 256>& crc_table() {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  return table;
}

void put_u32be(std::vector<std::uint8_t>& out, std::uint32_t v) {
  out.push_back(static_cast<std::uint8_t>(v >> 24));
  out.push_back(static_cast<std::uint8_t>(v >> 16));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
  out.push_back(static_cast<std::uint8_t>(v));
}

std::uint32_t get_u32be(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

void put_chunk(std::vector<std::uint8_t>& out, const char type[4], std::span<const std::uint8_t> data) {
  put_u32be(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t type_pos = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  const std::uint32_t crc = crc32(std::span<const std::uint8_t>(out.data() + type_pos, 4 + data.size()));
  put_u32be(out, crc);
}

// zlib stream of stored deflate blocks (max 65535 bytes each).
std::vector<std::uint8_t> zlib_stored(std::span<const std::uint8_t> raw) {
  std::vector<std::uint8_t> z;
  z.reserve(raw.size() + raw.size() / 65535 * 5 + 16);
  z.push_back(0x78);  // CM=8 (deflate), CINFO=7 (32k window)
  z.push_back(0x01);  // FLEVEL=0, FCHECK so that 0x7801 % 31 == 0
  std::size_t pos = 0;
  do {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - pos);
    const bool final = pos + n == raw.size();
    z.push_back(final ? 1 : 0);  // BFINAL, BTYPE=00 (stored)
    z.push_back(static_cast<std::uint8_t>(n & 0xFF));
    z.push_back(static_cast<std::uint8_t>(n >> 8));
    z.push_back(static_cast<std::uint8_t>(~n & 0xFF));
    z.push_back(static_cast<std::uint8_t>((~n >> 8) & 0xFF));
    z.insert(z.end(), raw.begin() + static_cast<std::ptrdiff_t>(pos),
             raw.begin() + static_cast<std::ptrdiff_t>(pos + n));
    pos += n;
  } while (pos < raw.size());
  put_u32be(z, adler32(raw));
  return z;
}

std::vector<std::uint8_t> encode(int width, int height, std::uint8_t bit_depth, std::uint8_t color_type,
                                 std::span<const std::uint8_t> rows_without_filter, std::size_t row_bytes) {
  std::vector<std::uint8_t> raw;
  raw.reserve(static_cast<std::size_t>(height) * (row_bytes + 1));
  for (int y = 0; y < height; ++y) {
    raw.push_back(0);  // filter type None
    const auto* row = rows_without_filter.data() + static_cast<std::size_t>(y) * row_bytes;
    raw.insert(raw.end(), row, row + row_bytes);
  }
  std::vector<std::uint8_t> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<std::uint8_t> ihdr;
  put_u32be(ihdr, static_cast<std::uint32_t>(width));
  put_u32be(ihdr, static_cast<std::uint32_t>(height));
  ihdr.push_back(bit_depth);
  ihdr.push_back(color_type);
  ihdr.push_back(0);  // compression: deflate
  ihdr.push_back(0);  // filter method 0
  ihdr.push_back(0);  // no interlace
  put_chunk(out, "IHDR", ihdr);
  put_chunk(out, "IDAT", zlib_stored(raw));
  put_chunk(out, "IEND", {});
  return out;
}

bool write_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes, std::string& error) {
  std::ofstream f(path, std::ios::binary);
  if (!f) {
    error = "cannot write " + path;
    return false;
  }
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!f) {
    error = "write failed: " + path;
    return false;
  }
  return true;
}

}  // namespace

std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc) {
  const auto& t = crc_table();
  std::uint32_t c = crc ^ 0xFFFFFFFFu;
  for (std::uint8_t b : bytes) c = t[(c ^ b) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

std::uint32_t adler32(std::span<const std::uint8_t> bytes, std::uint32_t adler) {
  constexpr std::uint32_t kMod = 65521;
  std::uint32_t a = adler & 0xFFFF, b = adler >> 16;
  std::size_t i = 0;
  while (i < bytes.size()) {
    const std::size_t n = std::min<std::size_t>(5552, bytes.size() - i);  // no overflow before mod
    for (std::size_t k = 0; k < n; ++k) {
      a += bytes[i + k];
      b += a;
    }
    a %= kMod;
    b %= kMod;
    i += n;
  }
  return (b << 16) | a;
}

std::vector<std::uint8_t> encode_png(const Image16& image) {
  std::vector<std::uint8_t> be(image.pixels.size() * 2);
  for (std::size_t i = 0; i < image.pixels.size(); ++i) {  // PNG samples are big endian
    be[2 * i] = static_cast<std::uint8_t>(image.pixels[i] >> 8);
    be[2 * i + 1] = static_cast<std::uint8_t>(image.pixels[i] & 0xFF);
  }
  return encode(image.width, image.height, 16, 0, be, static_cast<std::size_t>(image.width) * 2);
}

std::vector<std::uint8_t> encode_png(const ImageRgb& image) {
  return encode(image.width, image.height, 8, 2, image.pixels, static_cast<std::size_t>(image.width) * 3);
}

bool write_png(const std::string& path, const Image16& image, std::string& error) {
  return write_bytes(path, encode_png(image), error);
}
bool write_png(const std::string& path, const ImageRgb& image, std::string& error) {
  return write_bytes(path, encode_png(image), error);
}

bool decode_png16(std::span<const std::uint8_t> bytes, Image16& out, std::string& error) {
  static const std::uint8_t kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (bytes.size() < 8 || !std::equal(kSig, kSig + 8, bytes.begin())) {
    error = "not a PNG";
    return false;
  }
  std::size_t pos = 8;
  std::vector<std::uint8_t> zdata;
  int width = 0, height = 0;
  while (pos + 12 <= bytes.size()) {
    const std::uint32_t len = get_u32be(&bytes[pos]);
    if (len > bytes.size() - pos - 12) {
      error = "truncated PNG chunk";
      return false;
    }
    const std::uint8_t* type = &bytes[pos + 4];
    const std::uint8_t* data = &bytes[pos + 8];
    if (crc32(std::span<const std::uint8_t>(type, len + 4)) != get_u32be(data + len)) {
      error = "PNG chunk CRC mismatch";
      return false;
    }
    const std::string t(reinterpret_cast<const char*>(type), 4);
    if (t == "IHDR") {
      if (len != 13) { error = "bad IHDR"; return false; }
      width = static_cast<int>(get_u32be(data));
      height = static_cast<int>(get_u32be(data + 4));
      if (data[8] != 16 || data[9] != 0 || data[12] != 0 || width <= 0 || height <= 0 ||
          width > 1 << 15 || height > 1 << 15) {
        error = "only non-interlaced 16-bit grayscale PNG is supported";
        return false;
      }
    } else if (t == "IDAT") {
      zdata.insert(zdata.end(), data, data + len);
    } else if (t == "IEND") {
      break;
    }
    pos += 12 + len;
  }
  if (width == 0 || zdata.size() < 6) {
    error = "PNG without IHDR/IDAT";
    return false;
  }
  // Inflate stored blocks only.
  std::vector<std::uint8_t> raw;
  std::size_t z = 2;
  bool final = false;
  while (!final) {
    if (z + 5 > zdata.size()) { error = "truncated deflate stream"; return false; }
    const std::uint8_t hdr = zdata[z];
    final = hdr & 1;
    if (((hdr >> 1) & 3) != 0) { error = "compressed deflate blocks are not supported"; return false; }
    const std::size_t n = zdata[z + 1] | (std::size_t{zdata[z + 2]} << 8);
    const std::size_t nn = zdata[z + 3] | (std::size_t{zdata[z + 4]} << 8);
    if ((n ^ 0xFFFF) != nn || z + 5 + n > zdata.size()) { error = "bad stored block"; return false; }
    raw.insert(raw.end(), zdata.begin() + static_cast<std::ptrdiff_t>(z + 5),
               zdata.begin() + static_cast<std::ptrdiff_t>(z + 5 + n));
    z += 5 + n;
  }
  if (z + 4 > zdata.size() || adler32(raw) != get_u32be(&zdata[z])) {
    error = "Adler-32 mismatch";
    return false;
  }
  const std::size_t row = static_cast<std::size_t>(width) * 2 + 1;
  if (raw.size() != row * static_cast<std::size_t>(height)) { error = "PNG size mismatch"; return false; }
  out.width = width;
  out.height = height;
  out.pixels.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* r = &raw[static_cast<std::size_t>(y) * row];
    if (r[0] != 0) { error = "only PNG filter type 0 is supported"; return false; }
    for (int x = 0; x < width; ++x) {
      out.pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)] =
          static_cast<std::uint16_t>((r[1 + 2 * x] << 8) | r[2 + 2 * x]);
    }
  }
  return true;
}

bool read_png16(const std::string& path, Image16& out, std::string& error) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    error = "cannot open " + path;
    return false;
  }
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return decode_png16(bytes, out, error);
}

}  // namespace v2xloc::sim
