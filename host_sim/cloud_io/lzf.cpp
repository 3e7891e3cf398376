// LZF blocks of PCD's DATA binary_compressed, through the system liblzf (the library PCL uses).
#include "host_sim/cloud_io/pcd.hpp"

#include <lzf.h>

#include <climits>
#include <cstring>

namespace v2xloc::cloud_io {
namespace {

// liblzf keeps its 64 Ki-slot hash table on the stack without clearing it (built with INIT_HTAB 0):
// stale words left there by earlier calls can select different, equally valid matches, so the same
// cloud could compress to different bytes. Zeroing that stack region first keeps recordings
// byte-identical for the same seed. 64 Ki slots x 8 bytes = 512 KiB; a little more for its frame.
[[gnu::noinline]] void clear_stack_below() {
  volatile unsigned char scratch[544 * 1024];
  std::memset(const_cast<unsigned char*>(scratch), 0, sizeof scratch);
}

}  // namespace

std::size_t lzf_decompress(std::span<const std::uint8_t> in, std::span<std::uint8_t> out) {
  // liblzf takes unsigned int lengths; PCD stores 32-bit sizes, so larger spans are corrupt here.
  if (in.empty() || out.empty() || in.size() > UINT_MAX || out.size() > UINT_MAX) return 0;
  return ::lzf_decompress(in.data(), static_cast<unsigned>(in.size()), out.data(), static_cast<unsigned>(out.size()));
}

bool lzf_compress(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out) {
  out.clear();
  if (in.empty()) return true;
  // Incompressible input grows by one control byte per 32 literals (liblzf: "less than 104%").
  const std::size_t bound = in.size() + in.size() / 32 + 16;
  if (bound > UINT_MAX) return false;
  out.resize(bound);
  clear_stack_below();
  const unsigned n = ::lzf_compress(in.data(), static_cast<unsigned>(in.size()), out.data(), static_cast<unsigned>(bound));
  out.resize(n);
  return n > 0;
}

}  // namespace v2xloc::cloud_io
