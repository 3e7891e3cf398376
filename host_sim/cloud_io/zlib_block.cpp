// zlib blocks and byte planes of the quantised cloud encoding (pcd.hpp, DATA binary_shuffled_zlib),
// through the system zlib; reading through libdeflate where it is installed (same bytes, same checks).
#include "host_sim/cloud_io/pcd.hpp"

#include <zlib.h>
#if V2XLOC_HAVE_LIBDEFLATE
#include <libdeflate.h>
#endif

#include <climits>

namespace v2xloc::cloud_io {

bool zlib_compress(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out) {
  out.clear();
  if (in.size() > UINT_MAX) return false;  // zlib's uLong is 32 bits on some targets
  uLongf size = compressBound(static_cast<uLong>(in.size()));
  out.resize(size);
  // Level 6 (zlib's default) is fixed: the same input gives the same bytes with the same zlib.
  if (compress2(out.data(), &size, in.data(), static_cast<uLong>(in.size()), 6) != Z_OK) {
    out.clear();
    return false;
  }
  out.resize(size);
  return true;
}

std::size_t zlib_decompress(std::span<const std::uint8_t> in, std::span<std::uint8_t> out) {
  if (in.empty() || out.empty() || in.size() > UINT_MAX || out.size() > UINT_MAX) return 0;
#if V2XLOC_HAVE_LIBDEFLATE
  // libdeflate inflates and checks the Adler-32 in about half of zlib's time (reading the clouds
  // was a third of a firmware replay's host work). One decompressor per thread, kept.
  struct Decompressor {
    libdeflate_decompressor* d = libdeflate_alloc_decompressor();
    ~Decompressor() { libdeflate_free_decompressor(d); }
  };
  thread_local Decompressor decompressor;
  std::size_t consumed = 0, written = 0;
  if (decompressor.d == nullptr ||
      libdeflate_zlib_decompress_ex(decompressor.d, in.data(), in.size(), out.data(), out.size(), &consumed,
                                    &written) != LIBDEFLATE_SUCCESS ||
      consumed != in.size()) {
    return 0;
  }
  return written;
#else
  uLongf written = static_cast<uLongf>(out.size());
  uLong consumed = static_cast<uLong>(in.size());
  // The stream must end exactly at the block's end and fill `out` exactly: anything else is a
  // corrupt or lying block.
  if (uncompress2(out.data(), &written, in.data(), &consumed) != Z_OK || consumed != in.size()) return 0;
  return written;
#endif
}

void shuffle_bytes(std::span<const std::uint8_t> in, std::size_t width, std::span<std::uint8_t> out) {
  const std::size_t n = width == 0 ? 0 : in.size() / width;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < width; ++k) out[k * n + i] = in[i * width + k];
}

}  // namespace v2xloc::cloud_io
