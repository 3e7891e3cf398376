// Process-wide allocation counter for the alloc-free tests. Counting is armed only inside an
// AllocationScope, so gtest's own allocations outside the measured calls do not count.
#pragma once

#include <cstdint>

namespace v2xloc::testing {

std::uint64_t allocation_count();   // operator new + malloc family while armed
bool malloc_is_counted();           // false under ASan (its allocator owns malloc)

class AllocationScope {
 public:
  AllocationScope();
  ~AllocationScope();
  std::uint64_t allocations() const;

 private:
  std::uint64_t start_;
};

}  // namespace v2xloc::testing
