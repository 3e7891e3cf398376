// LZF (Marc Lehmann's liblzf stream format, used by PCL for DATA binary_compressed).
// Control byte c: c < 32 -> literal run of c + 1 bytes; otherwise a back reference of
// length (c >> 5) + 2 (length field 7 means "add the next byte"), offset ((c & 31) << 8 | next) + 1.
#include "host_sim/cloud_io/pcd.hpp"

#include <algorithm>

namespace v2xloc::cloud_io {

std::size_t lzf_decompress(std::span<const std::uint8_t> in, std::span<std::uint8_t> out) {
  std::size_t ip = 0;
  std::size_t op = 0;
  while (ip < in.size()) {
    const std::size_t ctrl = in[ip++];
    if (ctrl < 32) {
      const std::size_t run = ctrl + 1;
      if (run > in.size() - ip || run > out.size() - op) return 0;
      for (std::size_t i = 0; i < run; ++i) out[op++] = in[ip++];
      continue;
    }
    std::size_t len = ctrl >> 5;
    if (len == 7) {
      if (ip >= in.size()) return 0;
      len += in[ip++];
    }
    len += 2;
    if (ip >= in.size()) return 0;
    const std::size_t offset = ((ctrl & 0x1f) << 8 | in[ip++]) + 1;
    if (offset > op || len > out.size() - op) return 0;
    // Byte by byte: the source may overlap the bytes being written (run-length style).
    for (std::size_t i = 0; i < len; ++i, ++op) out[op] = out[op - offset];
  }
  return op;
}

void lzf_compress(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out) {
  constexpr std::size_t kHashBits = 14;
  constexpr std::size_t kMaxOffset = 1 << 13;  // 13 offset bits
  constexpr std::size_t kMaxMatch = 7 + 255 + 2;
  constexpr std::size_t kMaxLiteral = 32;
  constexpr std::uint32_t kEmpty = 0xffffffffu;

  out.clear();
  out.reserve(in.size() + in.size() / 32 + 2);
  std::vector<std::uint32_t> table(std::size_t{1} << kHashBits, kEmpty);
  const std::size_t n = in.size();

  auto flush_literals = [&](std::size_t from, std::size_t to) {
    while (from < to) {
      const std::size_t run = std::min(kMaxLiteral, to - from);
      out.push_back(static_cast<std::uint8_t>(run - 1));
      out.insert(out.end(), in.begin() + static_cast<std::ptrdiff_t>(from),
                 in.begin() + static_cast<std::ptrdiff_t>(from + run));
      from += run;
    }
  };

  std::size_t literal_start = 0;
  std::size_t ip = 0;
  while (ip + 2 < n) {
    const std::uint32_t key =
        static_cast<std::uint32_t>(in[ip]) << 16 | static_cast<std::uint32_t>(in[ip + 1]) << 8 | in[ip + 2];
    const std::size_t slot = (key * 2654435761u) >> (32 - kHashBits);
    const std::uint32_t ref = table[slot];
    table[slot] = static_cast<std::uint32_t>(ip);
    if (ref != kEmpty && ip - ref <= kMaxOffset && in[ref] == in[ip] && in[ref + 1] == in[ip + 1] &&
        in[ref + 2] == in[ip + 2]) {
      const std::size_t max_len = std::min(kMaxMatch, n - ip);
      std::size_t len = 3;
      while (len < max_len && in[ref + len] == in[ip + len]) ++len;
      flush_literals(literal_start, ip);
      const std::size_t offset = ip - ref - 1;
      const std::size_t code = len - 2;
      if (code < 7) {
        out.push_back(static_cast<std::uint8_t>(code << 5 | offset >> 8));
      } else {
        out.push_back(static_cast<std::uint8_t>(7 << 5 | offset >> 8));
        out.push_back(static_cast<std::uint8_t>(code - 7));
      }
      out.push_back(static_cast<std::uint8_t>(offset & 0xff));
      ip += len;
      literal_start = ip;
    } else {
      ++ip;
    }
  }
  flush_literals(literal_start, n);
}

}  // namespace v2xloc::cloud_io
