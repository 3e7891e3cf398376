// Counts heap allocations through the global operator new (all forms) while armed. Linking
// alloc_counter.cpp replaces operator new for the whole program; the firmware arms it after
// start-up and reports the count at exit ("the firmware allocates nothing after start-up").
#pragma once

#include <cstdint>

namespace v2xloc::firmware::alloc_counter {

void arm(bool on);
std::uint64_t allocations();     // while armed
std::uint64_t bytes();

}  // namespace v2xloc::firmware::alloc_counter
