// Keeping k of n items evenly along their order: item j is kept when floor(j k / n) steps up at
// j + 1, which happens exactly k times, the last item always among them; a kept item's rank among
// the kept is floor((j + 1) k / n) - 1. Depends on the index alone, so the items may be visited
// in any order. Integer arithmetic: the same choice on every ISA.
#pragma once

#include <cstdint>

namespace v2xloc {

inline bool kept_evenly(std::uint64_t j, std::uint64_t n, std::uint64_t k) {
  return (j + 1) * k / n > j * k / n;
}

inline std::uint64_t kept_rank(std::uint64_t j, std::uint64_t n, std::uint64_t k) { return (j + 1) * k / n - 1; }

}  // namespace v2xloc
