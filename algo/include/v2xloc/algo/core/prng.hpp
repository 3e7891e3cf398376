// Seeded pseudo-random numbers with the same sequence on every platform: PCG32 (XSH-RR variant,
// O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good Algorithms").
// <random> engines are portable but its distributions are implementation-defined, and
// std::random_device is an OS call, so neither is used in the core.
#pragma once

#include <cstdint>

namespace v2xloc {

class Pcg32 {
 public:
  explicit Pcg32(std::uint64_t seed = 0x853c49e6748fea9bULL, std::uint64_t stream = 0xda3e39cb94b95bdbULL) {
    reseed(seed, stream);
  }

  // PCG's reference seeding: the stream selects the increment (must be odd).
  void reseed(std::uint64_t seed, std::uint64_t stream = 0xda3e39cb94b95bdbULL) {
    state_ = 0;
    increment_ = (stream << 1u) | 1u;
    next_u32();
    state_ += seed;
    next_u32();
  }

  std::uint32_t next_u32() {
    const std::uint64_t old = state_;
    state_ = old * kMultiplier + increment_;
    const auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
    const auto rot = static_cast<std::uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }

  // Uniform integer in [0, bound) without modulo bias: Lemire's multiply-shift with rejection
  // ("Fast Random Integer Generation in an Interval", ACM TOMACS 2019). bound == 0 returns 0.
  std::uint32_t uniform_below(std::uint32_t bound) {
    if (bound == 0) return 0;
    std::uint64_t product = static_cast<std::uint64_t>(next_u32()) * bound;
    auto low = static_cast<std::uint32_t>(product);
    if (low < bound) {
      const std::uint32_t threshold = static_cast<std::uint32_t>(-bound) % bound;  // 2^32 mod bound
      while (low < threshold) {
        product = static_cast<std::uint64_t>(next_u32()) * bound;
        low = static_cast<std::uint32_t>(product);
      }
    }
    return static_cast<std::uint32_t>(product >> 32u);
  }

  // Uniform double in [0, 1) with 53 random bits (exactly representable, no rounding up to 1).
  double uniform01() {
    const std::uint64_t high = next_u32() >> 5u;  // 27 bits
    const std::uint64_t low = next_u32() >> 6u;   // 26 bits
    return static_cast<double>((high << 26u) | low) * (1.0 / 9007199254740992.0);  // 2^-53
  }

  // Uniform double in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform01(); }

 private:
  static constexpr std::uint64_t kMultiplier = 6364136223846793005ULL;
  std::uint64_t state_ = 0;
  std::uint64_t increment_ = 1;
};

}  // namespace v2xloc
