#include "alloc_counter.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#if defined(__SANITIZE_ADDRESS__)
#define V2XLOC_COUNT_MALLOC 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define V2XLOC_COUNT_MALLOC 0
#endif
#endif
#if !defined(V2XLOC_COUNT_MALLOC) && defined(__GLIBC__)
#define V2XLOC_COUNT_MALLOC 1
#endif
#if !defined(V2XLOC_COUNT_MALLOC)
#define V2XLOC_COUNT_MALLOC 0
#endif

namespace {
std::atomic<bool> g_armed{false};
std::atomic<std::uint64_t> g_count{0};
inline void note() {
  if (g_armed.load(std::memory_order_relaxed)) g_count.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

namespace v2xloc::testing {
std::uint64_t allocation_count() { return g_count.load(); }
bool malloc_is_counted() { return V2XLOC_COUNT_MALLOC != 0; }
AllocationScope::AllocationScope() : start_(g_count.load()) { g_armed.store(true); }
AllocationScope::~AllocationScope() { g_armed.store(false); }
std::uint64_t AllocationScope::allocations() const { return g_count.load() - start_; }
}  // namespace v2xloc::testing

#if V2XLOC_COUNT_MALLOC
// glibc exports its allocator under __libc_* names; forwarding to them lets us interpose the
// public symbols without recursion.
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* malloc(std::size_t n) {
  note();
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t s) {
  note();
  return __libc_calloc(n, s);
}
void* realloc(void* p, std::size_t n) {
  note();
  return __libc_realloc(p, n);
}
}
#endif

// Every replaceable allocation function funnels through these two.
void* operator new(std::size_t n) {
  note();
  if (n == 0) n = 1;
  void* p = std::malloc(n);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  note();
  return std::malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void* operator new(std::size_t n, std::align_val_t a) {
  note();
  const std::size_t al = static_cast<std::size_t>(a);
  void* p = std::aligned_alloc(al, ((n == 0 ? 1 : n) + al - 1) / al * al);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* operator new[](std::size_t n, std::align_val_t a) { return operator new(n, a); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
