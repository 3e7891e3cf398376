// Static memory for mbedTLS: the firmware's copy of libmbedcrypto has calloc/free renamed to
// v2xloc_crypto_calloc/free (CMakeLists.txt), served here from one static array. Size classes of
// powers of two (32 B .. 64 KiB) with a free list each: mbedTLS's bignum allocations repeat the
// same sizes every verification, so after the first one the arena stops growing (test:
// tests/unit/trust). Exhaustion returns nullptr: mbedTLS reports MBEDTLS_ERR_MPI_ALLOC_FAILED and
// the verification fails (counted), the heap is never touched. Single-threaded (the firmware's
// poll loop is the only caller).
#pragma once

#include <cstddef>
#include <cstdint>

namespace v2xloc::trust {

inline constexpr std::size_t kCryptoArenaBytes = 64 * 1024;  // P-256 sign/verify carve ~10 KiB (test)

struct CryptoArenaStats {
  std::uint64_t allocations = 0;
  std::uint64_t failed = 0;         // arena exhausted or request too large
  std::size_t carved_bytes = 0;     // high-water mark of the bump pointer
  std::size_t live_bytes = 0;
  std::size_t peak_live_bytes = 0;
};

const CryptoArenaStats& crypto_arena_stats();

}  // namespace v2xloc::trust

extern "C" {
void* v2xloc_crypto_calloc(std::size_t count, std::size_t size);
void v2xloc_crypto_free(void* p);
}
