// Google Benchmark: one ego LiDAR sweep (64 x 1024), one infra sweep (32 x 1024) and one stereo
// disparity frame (621 x 187) in the Sim 3 world, single thread.
#include "host_sim/scenario/simulation.hpp"
#include "host_sim/sensors/lidar.hpp"
#include "host_sim/sensors/stereo.hpp"

#include <benchmark/benchmark.h>

namespace {

using namespace v2xloc::sim;

const Simulation& sim() {
  static Simulation s = [] {
    Simulation out;
    build_simulation(3, 1, 0.0, WorldConfig{}, out);
    return out;
  }();
  return s;
}

void BM_EgoLidarSweep(benchmark::State& state) {
  const Simulation& s = sim();
  const LidarConfig cfg = ego_lidar_config(false);
  Rng rng(1);
  LidarScan scan;
  double t = 5.0;
  for (auto _ : state) {
    render_lidar_sweep(s.iw.world, cfg, [&](double tt) { return s.scenario.ego.body_to_enu(tt); }, t, s.ego_body, rng, scan);
    benchmark::DoNotOptimize(scan.points.data());
    t += 0.1;
  }
  state.counters["points"] = static_cast<double>(scan.points.size());
  state.counters["rays_per_s"] = benchmark::Counter(static_cast<double>(scan.rays), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_EgoLidarSweep)->Unit(benchmark::kMillisecond);

void BM_InfraLidarSweep(benchmark::State& state) {
  const Simulation& s = sim();
  const LidarConfig cfg = infra_lidar_config(false);
  const auto site = infra_sites(Permutation::k4Infra)[0].sensor_to_enu;
  Rng rng(2);
  LidarScan scan;
  for (auto _ : state) {
    render_lidar_sweep(s.iw.world, cfg, [&](double) { return site; }, 5.0, -1, rng, scan);
    benchmark::DoNotOptimize(scan.points.data());
  }
  state.counters["points"] = static_cast<double>(scan.points.size());
}
BENCHMARK(BM_InfraLidarSweep)->Unit(benchmark::kMillisecond);

void BM_StereoDisparity(benchmark::State& state) {
  const Simulation& s = sim();
  const StereoConfig cfg = ego_stereo_config(false);
  Rng rng(3);
  Image16 img;
  for (auto _ : state) {
    render_disparity(s.iw.world, cfg, s.scenario.ego.body_to_enu(5.0), 5.0, s.ego_body, rng, img);
    benchmark::DoNotOptimize(img.pixels.data());
  }
}
BENCHMARK(BM_StereoDisparity)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
