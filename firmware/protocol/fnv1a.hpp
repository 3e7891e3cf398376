// FNV-1a, 64-bit, over raw bytes: the digests runs print to be compared bit for bit (the period
// driver's IMU samples, the target harness's period outputs). Not a cryptographic hash.
#pragma once

#include <cstddef>
#include <cstdint>

namespace v2xloc::firmware {

inline constexpr std::uint64_t kFnv1aOffsetBasis = 0xcbf29ce484222325ull;

struct Fnv1a64 {
  std::uint64_t h = kFnv1aOffsetBasis;
  void bytes(const void* data, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 0x100000001b3ull;
  }
};

}  // namespace v2xloc::firmware
