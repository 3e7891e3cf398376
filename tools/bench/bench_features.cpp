// Benchmarks of the feature stages on the real outdoor scan (tests/data/outdoor_lidar_pair),
// with the Open3D registration-tutorial parameters at voxel 0.5 m: normals 1.0 m / 30 nn,
// FPFH 2.5 m / 100 nn. Without the data file the benchmarks report an error and skip.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "v2xloc/algo/registration/correspondences.hpp"
#include "v2xloc/algo/registration/fpfh.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/registration/voxel_downsample.hpp"

namespace v2xloc {
namespace {

constexpr float kVoxel = 0.5f;

// Minimal binary little-endian PLY reader for float32-only vertex properties (x, y, z first).
std::vector<Vec3f> read_float_ply(const std::string& path) {
  std::vector<Vec3f> pts;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return pts;
  char line[256];
  std::size_t count = 0, props = 0;
  bool binary_le = false;
  while (std::fgets(line, sizeof line, f) != nullptr) {
    if (std::strncmp(line, "format binary_little_endian", 27) == 0) binary_le = true;
    if (std::sscanf(line, "element vertex %zu", &count) == 1) continue;
    if (std::strncmp(line, "property float", 14) == 0) ++props;
    if (std::strncmp(line, "end_header", 10) == 0) break;
  }
  if (!binary_le || props < 3) {
    std::fclose(f);
    return pts;
  }
  std::vector<float> row(props);
  for (std::size_t i = 0; i < count && std::fread(row.data(), 4, props, f) == props; ++i) {
    pts.emplace_back(row[0], row[1], row[2]);
  }
  std::fclose(f);
  return pts;
}

struct Data {
  std::vector<Vec3f> source_raw, target_raw;
  FixedVector<Vec3f, config::kMaxDownsampledPoints> source, target;
};

Data& data() {
  static Data* d = [] {
    static Data storage;
    const std::string dir = std::string(V2XLOC_SHARED_DATA_DIR) + "/outdoor_lidar_pair/";
    storage.source_raw = read_float_ply(dir + "source.ply");
    storage.target_raw = read_float_ply(dir + "target.ply");
    static VoxelDownsampleStorage<> vs;
    vs.run(storage.source_raw, kVoxel, storage.source);
    vs.run(storage.target_raw, kVoxel, storage.target);
    return &storage;
  }();
  return *d;
}

static VoxelDownsampleStorage<> g_voxel;
static FixedVector<Vec3f, config::kMaxDownsampledPoints> g_down;
static KdTreeStorage<Vec3f, config::kMaxDownsampledPoints> g_tree;
static KdTreeStorage<Vec3f, config::kMaxDownsampledPoints> g_tree_target;
static KdTreeStorage<Feature33, config::kMaxDownsampledPoints> g_ftree_source;
static KdTreeStorage<Feature33, config::kMaxDownsampledPoints> g_ftree_target;
static Vec3f g_normals[config::kMaxDownsampledPoints];
static Vec3f g_normals_target[config::kMaxDownsampledPoints];
static Feature33 g_spfh[config::kMaxDownsampledPoints];
static Feature33 g_fpfh[config::kMaxDownsampledPoints];
static Feature33 g_fpfh_target[config::kMaxDownsampledPoints];
static FixedVector<Correspondence, config::kMaxCorrespondences> g_corr;
static std::uint32_t g_scratch[config::kMaxDownsampledPoints];

bool have_data(benchmark::State& state) {
  if (data().source_raw.empty()) {
    state.SkipWithError("outdoor_lidar_pair not found");
    return false;
  }
  return true;
}

NormalParams normal_params() {
  NormalParams p;
  p.radius = 2.0f * kVoxel;
  p.max_nn = 30;
  return p;
}
FpfhParams fpfh_params() {
  FpfhParams p;
  p.radius = 5.0f * kVoxel;
  p.max_nn = 100;
  return p;
}

void BM_VoxelDownsample(benchmark::State& state) {
  if (!have_data(state)) return;
  for (auto _ : state) {
    const auto r = g_voxel.run(data().source_raw, kVoxel, g_down);
    benchmark::DoNotOptimize(r.output_points);
  }
  state.counters["in"] = double(data().source_raw.size());
  state.counters["out"] = double(g_down.size());
}
BENCHMARK(BM_VoxelDownsample)->Unit(benchmark::kMillisecond);

void BM_KdBuild3D(benchmark::State& state) {
  if (!have_data(state)) return;
  for (auto _ : state) {
    const auto r = g_tree.build(data().source.span());
    benchmark::DoNotOptimize(r.nodes);
  }
}
BENCHMARK(BM_KdBuild3D)->Unit(benchmark::kMicrosecond);

void BM_KdHybrid3D(benchmark::State& state) {
  if (!have_data(state)) return;
  g_tree.build(data().source.span());
  Neighbor buf[config::kMaxNeighbors];
  const auto pts = data().source.span();
  std::size_t i = 0;
  for (auto _ : state) {
    const auto r = g_tree.tree.hybrid(pts[i], 2.5f, 100, std::span<Neighbor>(buf, 100));
    benchmark::DoNotOptimize(r.count);
    i = (i + 1) % pts.size();
  }
}
BENCHMARK(BM_KdHybrid3D);

void BM_Normals(benchmark::State& state) {
  if (!have_data(state)) return;
  g_tree.build(data().source.span());
  for (auto _ : state) {
    const auto r = estimate_normals(g_tree.tree, normal_params(), g_normals);
    benchmark::DoNotOptimize(r.points);
  }
  state.counters["points"] = double(data().source.size());
}
BENCHMARK(BM_Normals)->Unit(benchmark::kMillisecond);

void BM_Fpfh(benchmark::State& state) {
  if (!have_data(state)) return;
  g_tree.build(data().source.span());
  estimate_normals(g_tree.tree, normal_params(), g_normals);
  for (auto _ : state) {
    const auto r = compute_fpfh(g_tree.tree, g_normals, fpfh_params(), g_spfh, g_fpfh);
    benchmark::DoNotOptimize(r.points);
  }
  state.counters["points"] = double(data().source.size());
}
BENCHMARK(BM_Fpfh)->Unit(benchmark::kMillisecond);

void BM_CorrespondencesMutual(benchmark::State& state) {
  if (!have_data(state)) return;
  g_tree.build(data().source.span());
  estimate_normals(g_tree.tree, normal_params(), g_normals);
  compute_fpfh(g_tree.tree, g_normals, fpfh_params(), g_spfh, g_fpfh);
  g_tree_target.build(data().target.span());
  estimate_normals(g_tree_target.tree, normal_params(), g_normals_target);
  compute_fpfh(g_tree_target.tree, g_normals_target, fpfh_params(), g_spfh, g_fpfh_target);
  const std::span<const Feature33> src(g_fpfh, data().source.size());
  const std::span<const Feature33> tgt(g_fpfh_target, data().target.size());
  CorrespondenceParams p;
  p.mutual_filter = true;
  CorrespondenceResult r;
  for (auto _ : state) {
    // Both feature trees are rebuilt per run: that is what a registration call pays.
    g_ftree_source.build(src, 1u << 30);
    g_ftree_target.build(tgt, 1u << 30);
    r = match_features(src, g_ftree_target.tree, p, g_corr, &g_ftree_source.tree, g_scratch);
    benchmark::DoNotOptimize(r.count);
  }
  state.counters["matches"] = double(r.count);
  state.counters["visits/query"] = double(r.search.node_visits) / double(r.search.queries);
}
BENCHMARK(BM_CorrespondencesMutual)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace v2xloc
