#include "firmware/app/alloc_counter.hpp"

#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <new>

// malloc is counted only where it can be interposed safely: glibc (its allocator is reachable as
// __libc_*), and not under AddressSanitizer, whose allocator owns malloc.
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

namespace v2xloc::firmware::alloc_counter {
namespace {
std::atomic<bool> g_armed{false};
std::atomic<std::uint64_t> g_count{0};
std::atomic<std::uint64_t> g_bytes{0};
}  // namespace

namespace {
void note(std::size_t size) {
  if (g_armed.load(std::memory_order_relaxed)) {
    g_count.fetch_add(1, std::memory_order_relaxed);
    g_bytes.fetch_add(size, std::memory_order_relaxed);
  }
}
}  // namespace

void arm(bool on) { g_armed.store(on, std::memory_order_seq_cst); }
std::uint64_t allocations() { return g_count.load(); }
std::uint64_t bytes() { return g_bytes.load(); }
bool malloc_is_counted() { return V2XLOC_COUNT_MALLOC != 0; }

}  // namespace v2xloc::firmware::alloc_counter

namespace ac = v2xloc::firmware::alloc_counter;

#if V2XLOC_COUNT_MALLOC
// glibc exports its allocator under __libc_* names; forwarding to them lets us interpose the
// public symbols without recursion.
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* malloc(std::size_t n) {
  ac::note(n);
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t s) {
  ac::note(n * s);
  return __libc_calloc(n, s);
}
void* realloc(void* p, std::size_t n) {
  ac::note(n);
  return __libc_realloc(p, n);
}
}
#endif

namespace {
// Every operator new form funnels through here and is counted once (not again by malloc).
void* allocate(std::size_t size, std::size_t alignment) {
  ac::note(size);
  if (size == 0) size = 1;
  if (alignment > alignof(std::max_align_t)) return std::aligned_alloc(alignment, (size + alignment - 1) / alignment * alignment);
#if V2XLOC_COUNT_MALLOC
  return __libc_malloc(size);
#else
  return std::malloc(size);
#endif
}
}  // namespace

void* operator new(std::size_t size) {
  if (void* p = allocate(size, 0)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  if (void* p = allocate(size, 0)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return allocate(size, 0); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return allocate(size, 0); }
void* operator new(std::size_t size, std::align_val_t a) {
  if (void* p = allocate(size, static_cast<std::size_t>(a))) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size, std::align_val_t a) {
  if (void* p = allocate(size, static_cast<std::size_t>(a))) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
