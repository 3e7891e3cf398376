// Deterministic random numbers for the simulator. std::normal_distribution is implementation
// defined, so we draw from our own generator (SplitMix64 seeding + xoshiro256**, Blackman & Vigna
// 2018) and our own Box-Muller transform: the same seed gives the same recording everywhere.
#pragma once

#include <cmath>
#include <cstdint>
#include <initializer_list>

namespace v2xloc::sim {

inline std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Mixes a seed with stream identifiers (sensor id, frame index, ...) so every frame of every
// sensor has its own independent stream: frames can be rendered in any order.
inline std::uint64_t derive_seed(std::uint64_t seed, std::initializer_list<std::uint64_t> keys) {
  std::uint64_t s = seed;
  std::uint64_t out = splitmix64(s);
  for (std::uint64_t k : keys) {
    s ^= k + 0x632BE59BD9B4E019ull + (out << 6) + (out >> 2);
    out = splitmix64(s);
  }
  return out;
}

class Rng {
 public:
  explicit Rng(std::uint64_t seed = 1) { reseed(seed); }
  void reseed(std::uint64_t seed) {
    std::uint64_t sm = seed;
    for (auto& w : s_) w = splitmix64(sm);
    has_spare_ = false;
  }
  std::uint64_t next_u64() {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  int uniform_int(int lo, int hi_inclusive) {
    const auto span = static_cast<std::uint64_t>(hi_inclusive - lo + 1);
    return lo + static_cast<int>(next_u64() % span);
  }
  bool bernoulli(double p) { return uniform() < p; }
  // Standard normal by the polar Box-Muller method (Marsaglia 1964).
  double gaussian() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double m = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * m;
    has_spare_ = true;
    return u * m;
  }
  double gaussian(double sigma) { return sigma * gaussian(); }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4] = {};
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace v2xloc::sim
