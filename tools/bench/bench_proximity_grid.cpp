// "A map point within 2 m?" (start-up pose-search hypothesis scoring): the proximity bitmap
// against the k-d tree's early-exit any_within, on a synthetic 100k-point street map (ground,
// facades, poles) in a 220 x 220 x 40 m box, and the bitmap's build.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <vector>

#include "v2xloc/algo/core/prng.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/search/proximity_grid.hpp"

namespace v2xloc {
namespace {

constexpr double kHalf = 110.0;
constexpr float kReach = 2.0f;

std::vector<Vec3f> street_map() {
  Pcg32 rng(7);
  std::vector<Vec3f> pts;
  pts.reserve(100000);
  const auto u = [&rng](double lo, double hi) { return static_cast<float>(rng.uniform(lo, hi)); };
  for (int i = 0; i < 50000; ++i) pts.emplace_back(u(-kHalf, kHalf), u(-kHalf, kHalf), u(-0.1, 0.1));
  for (int i = 0; i < 45000; ++i) {  // facades along x = +-12 m and y = +-12 m, 15 m high
    const float along = u(-kHalf, kHalf), side = rng.uniform_below(2) == 0 ? -12.0f : 12.0f;
    const float z = u(0.0, 15.0);
    pts.push_back(rng.uniform_below(2) == 0 ? Vec3f(side, along, z) : Vec3f(along, side, z));
  }
  for (int i = 0; i < 5000; ++i) {  // poles every 10 m
    const float x = 10.0f * static_cast<float>(rng.uniform_below(22)) - 105.0f;
    const float y = 10.0f * static_cast<float>(rng.uniform_below(22)) - 105.0f;
    pts.emplace_back(x, y, u(0.0, 6.0));
  }
  return pts;
}

// Scan-like queries: half near the ground, half spread up to 20 m high.
std::vector<Vec3f> queries() {
  Pcg32 rng(8);
  std::vector<Vec3f> q(4096);
  for (std::size_t i = 0; i < q.size(); ++i) {
    const double z = i % 2 == 0 ? rng.uniform(-0.5, 0.5) : rng.uniform(0.0, 20.0);
    q[i] = Vec3f(static_cast<float>(rng.uniform(-100.0, 100.0)), static_cast<float>(rng.uniform(-100.0, 100.0)),
                 static_cast<float>(z));
  }
  return q;
}

struct Fixture {
  std::vector<Vec3f> map = street_map();
  std::vector<Vec3f> q = queries();
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

ProximityGrid grid;
KdTreeStorage<Vec3f, 131072> tree;

void BM_ProximityGridNear(benchmark::State& state) {
  Fixture& f = fixture();
  grid.build(f.map, Vec3d(0.0, 0.0, 10.0), Vec3d(kHalf, kHalf, 20.0), {1.0f, kReach});
  std::uint64_t hits = 0;
  for (auto _ : state) {
    for (const Vec3f& q : f.q) hits += grid.near(q) ? 1u : 0u;
  }
  benchmark::DoNotOptimize(hits);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * f.q.size()));
  state.counters["hit_rate"] = static_cast<double>(hits) / static_cast<double>(state.iterations() * f.q.size());
  state.counters["cell_m"] = grid.cell();
}
BENCHMARK(BM_ProximityGridNear);

void BM_KdTreeAnyWithin(benchmark::State& state) {
  Fixture& f = fixture();
  tree.build(f.map);
  std::uint64_t hits = 0;
  for (auto _ : state) {
    for (const Vec3f& q : f.q) hits += tree.tree.any_within(q, kReach * kReach) ? 1u : 0u;
  }
  benchmark::DoNotOptimize(hits);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * f.q.size()));
  state.counters["hit_rate"] = static_cast<double>(hits) / static_cast<double>(state.iterations() * f.q.size());
}
BENCHMARK(BM_KdTreeAnyWithin);

void BM_ProximityGridBuild(benchmark::State& state) {
  Fixture& f = fixture();
  for (auto _ : state) {
    grid.build(f.map, Vec3d(0.0, 0.0, 10.0), Vec3d(kHalf, kHalf, 20.0), {1.0f, kReach});
    benchmark::DoNotOptimize(grid.words().data());
  }
  state.counters["work_units"] = static_cast<double>(grid.total_work());
}
BENCHMARK(BM_ProximityGridBuild)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace v2xloc
