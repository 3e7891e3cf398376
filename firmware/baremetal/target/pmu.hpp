// The Armv8-R / Armv8-A AArch32 performance monitors: retired instructions (event 0x08 on
// counter 0) and the cycle counter. The same registers on R52 silicon; under QEMU they count
// exactly with -icount shift=0 (docs/target.md). 32-bit counters: callers take differences.
#pragma once

#include <cstdint>

namespace v2xloc::target {

inline void pmu_start() {
  asm volatile("mcr p15, 0, %0, c9, c12, 5" ::"r"(0u));           // PMSELR: counter 0
  asm volatile("mcr p15, 0, %0, c9, c13, 1" ::"r"(0x08u));        // PMXEVTYPER: INST_RETIRED
  asm volatile("mcr p15, 0, %0, c9, c12, 1" ::"r"(0x80000001u));  // PMCNTENSET: cycles, counter 0
  asm volatile("mcr p15, 0, %0, c9, c12, 0" ::"r"(0x7u));         // PMCR: E | P (reset) | C (reset)
  asm volatile("isb");
}

inline std::uint32_t pmu_instructions() {
  std::uint32_t v;
  asm volatile("mrc p15, 0, %0, c9, c13, 2" : "=r"(v));  // PMXEVCNTR (PMSELR stays 0)
  return v;
}

inline std::uint32_t pmu_cycles() {
  std::uint32_t v;
  asm volatile("mrc p15, 0, %0, c9, c13, 0" : "=r"(v));  // PMCCNTR
  return v;
}

}  // namespace v2xloc::target
