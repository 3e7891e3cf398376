#include "firmware/trust/crypto_arena.hpp"

#include <cstring>

namespace v2xloc::trust {
namespace {

constexpr std::size_t kMinClassShift = 5;   // 32 B
constexpr std::size_t kMaxClassShift = 16;  // 64 KiB
constexpr std::size_t kClasses = kMaxClassShift - kMinClassShift + 1;
constexpr std::size_t kHeader = 16;         // keeps payloads 16-byte aligned

struct FreeBlock {
  FreeBlock* next;
};

alignas(16) unsigned char g_arena[kCryptoArenaBytes];
std::size_t g_top = 0;
FreeBlock* g_free[kClasses] = {};
CryptoArenaStats g_stats{};

std::size_t class_of(std::size_t bytes) {
  std::size_t c = 0;
  while ((std::size_t{1} << (kMinClassShift + c)) < bytes) ++c;
  return c;
}

}  // namespace

const CryptoArenaStats& crypto_arena_stats() { return g_stats; }

}  // namespace v2xloc::trust

using namespace v2xloc::trust;

extern "C" void* v2xloc_crypto_calloc(std::size_t count, std::size_t size) {
  if (count != 0 && size > (std::size_t{1} << kMaxClassShift) / count) {
    ++g_stats.failed;
    return nullptr;
  }
  const std::size_t bytes = count * size + kHeader;
  if (bytes > (std::size_t{1} << kMaxClassShift)) {
    ++g_stats.failed;
    return nullptr;
  }
  const std::size_t c = class_of(bytes);
  const std::size_t block = std::size_t{1} << (kMinClassShift + c);
  unsigned char* p = nullptr;
  if (g_free[c] != nullptr) {
    p = reinterpret_cast<unsigned char*>(g_free[c]);
    g_free[c] = g_free[c]->next;
  } else {
    if (kCryptoArenaBytes - g_top < block) {
      ++g_stats.failed;
      return nullptr;
    }
    p = g_arena + g_top;
    g_top += block;
    g_stats.carved_bytes = g_top;
  }
  std::memset(p, 0, block);
  p[0] = static_cast<unsigned char>(c);
  ++g_stats.allocations;
  g_stats.live_bytes += block;
  if (g_stats.live_bytes > g_stats.peak_live_bytes) g_stats.peak_live_bytes = g_stats.live_bytes;
  return p + kHeader;
}

extern "C" void v2xloc_crypto_free(void* q) {
  if (q == nullptr) return;
  unsigned char* p = static_cast<unsigned char*>(q) - kHeader;
  const std::size_t c = p[0];
  g_stats.live_bytes -= std::size_t{1} << (kMinClassShift + c);
  auto* b = reinterpret_cast<FreeBlock*>(p);
  b->next = g_free[c];
  g_free[c] = b;
}
