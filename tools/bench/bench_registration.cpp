// Per-stage benchmarks of the registration pipeline on the real outdoor LiDAR pair
// (tests/data/outdoor_lidar_pair), with the parameters tools/bench/compare_open3d.py gives
// Open3D: voxel 0.25 m, normals 2 voxels / 30 nn, FPFH 5 voxels / 100 nn, mutual matching,
// RANSAC 1.5 voxels (edge 0.9 + distance checkers, 100000 iterations, confidence 0.999),
// point-to-plane ICP at 1 voxel with Tukey k = 0.5 voxel. The full-pipeline benchmarks report the error vs the reference
// as counters (te_m, re_deg, success).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "v2xloc/algo/registration/register_clouds.hpp"

namespace {

using namespace v2xloc;

constexpr float kVoxel = 0.25f;

// Minimal binary little-endian PLY reader (x, y, z float; other float properties skipped).
bool read_ply(const std::string& path, std::vector<Vec3f>& out) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::size_t n = 0, props = 0;
  int ix = -1, iy = -1, iz = -1;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string key, a, b;
    ss >> key >> a >> b;
    if (key == "element" && a == "vertex") n = std::stoul(b);
    if (key == "property") {
      if (b == "x") ix = int(props);
      if (b == "y") iy = int(props);
      if (b == "z") iz = int(props);
      ++props;
    }
    if (key == "end_header") break;
  }
  if (ix < 0 || iy < 0 || iz < 0 || n == 0) return false;
  std::vector<float> rec(props);
  out.clear();
  for (std::size_t i = 0; i < n && in.read(reinterpret_cast<char*>(rec.data()), std::streamsize(props * 4)); ++i) {
    out.emplace_back(rec[ix], rec[iy], rec[iz]);
  }
  return out.size() == n;
}

bool read_matrix(const std::string& path, Mat4d& m) {
  std::ifstream in(path);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (!(in >> m(r, c))) return false;
    }
  }
  return true;
}

struct Data {
  std::vector<Vec3f> source, target;
  Mat4d reference = Mat4d::Identity();
  bool ok = false;
};

const Data& data() {
  static Data d = [] {
    Data x;
    const std::string dir = std::string(V2XLOC_SHARED_DATA_DIR) + "/outdoor_lidar_pair";
    x.ok = read_ply(dir + "/source.ply", x.source) && read_ply(dir + "/target.ply", x.target) &&
           read_matrix(dir + "/T_target_source.txt", x.reference);
    return x;
  }();
  return d;
}

RegistrationWorkspace g_ws;
Mat4d g_coarse = Mat4d::Identity();  // RANSAC result of the set-up run: where ICP starts

RegisterCloudsParams pipeline_params() {
  RegisterCloudsParams p;
  p.voxel_size = kVoxel;
  return p;
}

// Fills the workspace (downsampled clouds, trees, normals, features, correspondences).
bool prepare(benchmark::State& state) {
  if (!data().ok) {
    state.SkipWithError("outdoor_lidar_pair not found");
    return false;
  }
  static bool done = false;
  if (!done) {
    g_coarse = register_clouds(data().source, data().target, pipeline_params(), Mat4d::Identity(), g_ws)
                   .coarse.transform;
    done = true;
  }
  return true;
}

void report_error(benchmark::State& state, const RegisterCloudsResult& r) {
  const Mat4d& e = r.registration.transform;
  const Mat4d& t = data().reference;
  const double te = (e.topRightCorner<3, 1>() - t.topRightCorner<3, 1>()).norm();
  const Mat3d d = e.topLeftCorner<3, 3>().transpose() * t.topLeftCorner<3, 3>();
  double c = (d.trace() - 1.0) / 2.0;
  c = c > 1.0 ? 1.0 : (c < -1.0 ? -1.0 : c);
  const double re = std::acos(c) * 57.29577951308232;
  state.counters["te_m"] = te;
  state.counters["re_deg"] = re;
  state.counters["success"] = (r.registration.ok() && te <= 0.05 && re <= 0.5) ? 1.0 : 0.0;
  state.counters["fitness"] = r.registration.fitness;
}

void BM_RegistrationDownsample(benchmark::State& state) {
  if (!prepare(state)) return;
  static VoxelDownsampleStorage<> voxel;
  for (auto _ : state) {
    voxel.run(data().source, kVoxel, g_ws.source_down);
    voxel.run(data().target, kVoxel, g_ws.target_down);
  }
}
BENCHMARK(BM_RegistrationDownsample)->Unit(benchmark::kMillisecond);

// The pipeline's flow per cloud: tree, one FPFH-radius search per point (KdNeighborhoods),
// normals from its prefix; BM_RegistrationFpfh then times the features from the same lists
// (in register_clouds the list search is booked to the FPFH stage).
KdNeighborhoods describe_lists(KdTreeStorage<Vec3f, RegistrationWorkspace::kMaxPoints>& tree,
                               BoundedVector<Vec3f>& cloud) {
  tree.build(cloud.span());
  KdNeighborhoods lists(tree.tree);
  lists.build(5.0f * kVoxel, config::kFpfhMaxNeighbors,
              std::span<KdNeighborhoods::Slot>(g_ws.neighborhood_entries, RegistrationWorkspace::kListEntries),
              std::span<std::uint32_t>(g_ws.mutual_scratch, RegistrationWorkspace::kMaxPoints),
              std::span<std::uint8_t>(g_ws.neighborhood_count, RegistrationWorkspace::kListPoints));
  return lists;
}

void BM_RegistrationNormals(benchmark::State& state) {
  if (!prepare(state)) return;
  NormalParams np;
  np.radius = 2.0f * kVoxel;
  for (auto _ : state) {
    const KdNeighborhoods s = describe_lists(g_ws.source_tree, g_ws.source_down);
    estimate_normals(s, np, std::span<Vec3f>(g_ws.source_normals, g_ws.source_down.size()));
    const KdNeighborhoods t = describe_lists(g_ws.target_tree, g_ws.target_down);
    estimate_normals(t, np, std::span<Vec3f>(g_ws.target_normals, g_ws.target_down.size()));
  }
}
BENCHMARK(BM_RegistrationNormals)->Unit(benchmark::kMillisecond);

void BM_RegistrationNeighborhoods(benchmark::State& state) {
  if (!prepare(state)) return;
  std::uint64_t visits = 0, queries = 0;
  for (auto _ : state) {
    const KdNeighborhoods s = describe_lists(g_ws.source_tree, g_ws.source_down);
    const KdNeighborhoods t = describe_lists(g_ws.target_tree, g_ws.target_down);
    visits = s.build_search().node_visits + t.build_search().node_visits;
    queries = s.build_search().queries + t.build_search().queries;
  }
  state.counters["visits_per_query"] = double(visits) / double(queries);
  std::uint32_t entries = 0;
  for (std::size_t i = 0; i < g_ws.target_down.size(); ++i) entries += g_ws.neighborhood_count[i];
  state.counters["list_length"] = double(entries) / double(g_ws.target_down.size());
}
BENCHMARK(BM_RegistrationNeighborhoods)->Unit(benchmark::kMillisecond);

void BM_RegistrationFpfh(benchmark::State& state) {
  if (!prepare(state)) return;
  FpfhParams fp;
  fp.radius = 5.0f * kVoxel;
  const std::size_t ns = g_ws.source_down.size(), nt = g_ws.target_down.size();
  // The list storage holds one cloud at a time (as in register_clouds): rebuild it per cloud,
  // outside the timed region (BM_RegistrationNeighborhoods times that).
  for (auto _ : state) {
    state.PauseTiming();
    const KdNeighborhoods s = describe_lists(g_ws.source_tree, g_ws.source_down);
    state.ResumeTiming();
    compute_fpfh(s, std::span<const Vec3f>(g_ws.source_normals, ns), fp,
                 std::span<Feature33>(g_ws.spfh_scratch, ns), std::span<Feature33>(g_ws.source_features, ns));
    state.PauseTiming();
    const KdNeighborhoods t = describe_lists(g_ws.target_tree, g_ws.target_down);
    state.ResumeTiming();
    compute_fpfh(t, std::span<const Vec3f>(g_ws.target_normals, nt), fp,
                 std::span<Feature33>(g_ws.spfh_scratch, nt), std::span<Feature33>(g_ws.target_features, nt));
  }
}
BENCHMARK(BM_RegistrationFpfh)->Unit(benchmark::kMillisecond);

// visits: the feature trees' node-visit budget per query (0 = exact, as the default pipeline).
void run_correspondences(benchmark::State& state, std::size_t visits) {
  if (!prepare(state)) return;
  const std::size_t ns = g_ws.source_down.size(), nt = g_ws.target_down.size();
  CorrespondenceParams cp;
  cp.mutual_filter = true;
  CorrespondenceResult cr;
  for (auto _ : state) {
    g_ws.source_feature_tree.build(std::span<const Feature33>(g_ws.source_features, ns));
    g_ws.target_feature_tree.build(std::span<const Feature33>(g_ws.target_features, nt));
    compute_feature_basis(std::span<const Feature33>(g_ws.source_features, ns),
                          std::span<const Feature33>(g_ws.target_features, nt), 4,
                          std::span<Feature33>(g_ws.spfh_scratch, RegistrationWorkspace::kMaxPoints),
                          g_ws.feature_basis);
    float* const proj = g_ws.spfh_scratch[0].data();
    const float max_abs = std::max(
        project_features(std::span<const Feature33>(g_ws.source_features, ns), g_ws.feature_basis, proj, kFpfhBins),
        project_features(std::span<const Feature33>(g_ws.target_features, nt), g_ws.feature_basis, proj + 8, kFpfhBins));
    cp.projections = {proj, proj + 8, kFpfhBins};
    g_ws.source_feature_tree.tree.set_projections(proj, kFpfhBins, max_abs);
    g_ws.target_feature_tree.tree.set_projections(proj + 8, kFpfhBins, max_abs);
    if (visits > 0) {
      g_ws.source_feature_tree.tree.set_max_node_visits(visits);
      g_ws.target_feature_tree.tree.set_max_node_visits(visits);
    }
    cr = match_features(std::span<const Feature33>(g_ws.source_features, ns), g_ws.target_feature_tree.tree, cp,
                   g_ws.correspondences, &g_ws.source_feature_tree.tree,
                   std::span<std::uint32_t>(g_ws.mutual_scratch, RegistrationWorkspace::kMaxPoints));
  }
  state.counters["correspondences"] = double(g_ws.correspondences.size());
  state.counters["queries"] = double(cr.search.queries);
  state.counters["visits_per_query"] = double(cr.search.node_visits) / double(cr.search.queries);
  state.counters["queries_cut"] = double(cr.search.visit_cap_hits);
}
void BM_RegistrationCorrespondences(benchmark::State& state) { run_correspondences(state, 0); }
BENCHMARK(BM_RegistrationCorrespondences)->Unit(benchmark::kMillisecond);
// RegisterCloudsParams::feature_search_visits = 24 (v2xloc-register --feature-visits 24).
void BM_RegistrationCorrespondencesVisits24(benchmark::State& state) { run_correspondences(state, 24); }
BENCHMARK(BM_RegistrationCorrespondencesVisits24)->Unit(benchmark::kMillisecond);

void BM_RegistrationRansac(benchmark::State& state) {
  if (!prepare(state)) return;
  RansacParams rp;
  rp.max_correspondence_distance = 1.5 * kVoxel;
  rp.distance_check_threshold = rp.max_correspondence_distance;
  RansacResult r;
  for (auto _ : state) {
    r = ransac(g_ws.source_down.span(), g_ws.target_down.span(), g_ws.correspondences.span(),
               g_ws.target_tree.tree, rp);
  }
  state.counters["validations"] = r.validations;
  state.counters["iterations"] = r.registration.iterations;
  state.counters["fitness"] = r.registration.fitness;
}
BENCHMARK(BM_RegistrationRansac)->Unit(benchmark::kMillisecond);

void BM_RegistrationIcp(benchmark::State& state) {
  if (!prepare(state)) return;
  IcpTarget view;
  view.points = g_ws.target_down.span();
  view.normals = std::span<const Vec3f>(g_ws.target_normals, g_ws.target_down.size());
  view.tree = &g_ws.target_tree.tree;
  IcpParams ip = pipeline_params().icp;  // the pipeline's kernel type
  ip.max_correspondence_distance = kVoxel;
  ip.kernel.scale = 0.5 * kVoxel;
  RegistrationResult r;
  for (auto _ : state) {
    r = icp(g_ws.source_down.span(), view, g_coarse, ip,
            std::span<std::uint32_t>(g_ws.mutual_scratch, RegistrationWorkspace::kMaxPoints));
  }
  state.counters["iterations"] = r.iterations;
  state.counters["fitness"] = r.fitness;
}
BENCHMARK(BM_RegistrationIcp)->Unit(benchmark::kMillisecond);

void BM_RegistrationGlobalPipeline(benchmark::State& state) {
  if (!prepare(state)) return;
  RegisterCloudsResult r;
  for (auto _ : state) {
    r = register_clouds(data().source, data().target, pipeline_params(), Mat4d::Identity(), g_ws);
  }
  report_error(state, r);
}
BENCHMARK(BM_RegistrationGlobalPipeline)->Unit(benchmark::kMillisecond);

void BM_RegistrationIcpOnlyPipeline(benchmark::State& state) {
  if (!prepare(state)) return;
  RegisterCloudsParams p = pipeline_params();
  p.mode = RegistrationMode::kIcpOnly;
  RegisterCloudsResult r;
  for (auto _ : state) r = register_clouds(data().source, data().target, p, Mat4d::Identity(), g_ws);
  report_error(state, r);
}
BENCHMARK(BM_RegistrationIcpOnlyPipeline)->Unit(benchmark::kMillisecond);

}  // namespace
