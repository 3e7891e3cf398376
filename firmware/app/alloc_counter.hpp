// The house's one heap-allocation counter. Linking alloc_counter.cpp replaces the global operator
// new (all forms) and, on glibc outside sanitizer builds, malloc / calloc / realloc, for the whole
// program; allocations are counted while armed. The firmware arms it after start-up and reports
// the count at exit ("the firmware allocates nothing after start-up"); the zero-allocation tests
// of the algo core and the firmware loop arm it around the calls they measure.
#pragma once

#include <cstdint>

namespace v2xloc::firmware::alloc_counter {

void arm(bool on);
std::uint64_t allocations();     // counted while armed, since program start
std::uint64_t bytes();
bool malloc_is_counted();        // false under ASan (its allocator owns malloc): operator new only

// Arms the counter for its lifetime and reports the allocations made meanwhile.
class Scope {
 public:
  Scope() : start_(alloc_counter::allocations()) { arm(true); }
  ~Scope() { arm(false); }
  Scope(const Scope&) = delete;
  Scope& operator=(const Scope&) = delete;
  std::uint64_t allocations() const { return alloc_counter::allocations() - start_; }

 private:
  std::uint64_t start_;
};

}  // namespace v2xloc::firmware::alloc_counter
