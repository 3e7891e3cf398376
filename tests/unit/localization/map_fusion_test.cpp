#include "v2xloc/algo/localization/map_fusion.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <random>
#include <vector>

#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {
namespace {

// A corner of two walls and the ground, in the world frame, 0.1 m spacing.
std::vector<Vec3d> corner_scene() {
  std::vector<Vec3d> pts;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 40; ++j) {
      pts.emplace_back(0.1 * i, 0.0, 0.1 * j);
      pts.emplace_back(0.0, 0.1 * i, 0.1 * j);
      pts.emplace_back(0.1 * i, 0.1 * j * 2.5, 0.0);
    }
  return pts;
}

std::vector<Vec3f> in_sensor_frame(const std::vector<Vec3d>& world, const Mat4d& world_T_sensor) {
  const Mat4d inv = se3_inverse(world_T_sensor);
  std::vector<Vec3f> out;
  for (const Vec3d& p : world)
    out.push_back((inv.topLeftCorner<3, 3>() * p + inv.topRightCorner<3, 1>()).cast<float>());
  return out;
}

Mat4d sensor_pose(double x, double y, double yaw) {
  Mat4d T = Mat4d::Identity();
  T.topLeftCorner<3, 3>() = rot_z(yaw);
  T(0, 3) = x;
  T(1, 3) = y;
  T(2, 3) = 3.0;
  return T;
}

// Four infrastructure units around the corner scene (ids 1..3 genuine, the last one the suspect).
std::array<Mat4d, 4> intersection_units() {
  return {sensor_pose(12.0, 12.0, 2.0), sensor_pose(-3.0, 12.0, 1.2), sensor_pose(12.0, -3.0, 2.6),
          sensor_pose(-4.0, -4.0, 0.8)};
}

// Genuine unit k (id 1 + k) sends its view of the scene at t = 1 s.
MapInsertStatus insert_genuine_unit(MapFusion& map, const std::vector<Vec3d>& scene, const std::array<Mat4d, 4>& units,
                                    std::size_t k) {
  return map.insert(static_cast<std::uint32_t>(1 + k), 1.0, Pose3d(units[k]), in_sensor_frame(scene, units[k]), true).status;
}

// The scene with every point moved along x (points moved, declared sensor pose kept).
std::vector<Vec3d> moved_along_x(const std::vector<Vec3d>& scene, double dx) {
  std::vector<Vec3d> moved = scene;
  for (Vec3d& p : moved) p.x() += dx;
  return moved;
}

MapFusion& fresh_map(const MapFusionParams& p = {}) {
  static MapFusion map;  // ~9 MB
  map.configure(p);
  return map;
}

TEST(MapFusion, ReplacementStaleAndAgeing) {
  MapFusionParams params;
  params.max_age = 1.0;
  MapFusion& map = fresh_map(params);
  const auto scene = corner_scene();
  const Mat4d pose_a = sensor_pose(12.0, 12.0, 2.0);
  auto r = map.insert(7, 10.0, Pose3d(pose_a), in_sensor_frame(scene, pose_a), true);
  ASSERT_EQ(r.status, MapInsertStatus::kInserted);
  const std::size_t n1 = map.point_count();
  EXPECT_GT(n1, 1000u);
  EXPECT_EQ(n1, r.stored_points);
  // The same source re-scans: replaced, not accumulated.
  r = map.insert(7, 10.1, Pose3d(pose_a), in_sensor_frame(scene, pose_a), true);
  EXPECT_EQ(r.status, MapInsertStatus::kReplaced);
  EXPECT_EQ(map.point_count(), n1);
  // Reordered (older) message: stale.
  r = map.insert(7, 10.05, Pose3d(pose_a), in_sensor_frame(scene, pose_a), true);
  EXPECT_EQ(r.status, MapInsertStatus::kStale);
  // A second (surveyed) source: points add up; consistent overlap accepted (shift probes agree).
  const Mat4d pose_b = sensor_pose(-5.0, 15.0, -0.7);
  r = map.insert(8, 10.5, Pose3d(pose_b), in_sensor_frame(scene, pose_b), true);
  EXPECT_EQ(r.status, MapInsertStatus::kInserted);
  EXPECT_GT(r.consistency_fitness, 0.95);
  EXPECT_GT(r.overlap_points, 1000u);
  EXPECT_GT(map.point_count(), n1);
  // Ageing: at t = 11.3 source 7 (10.1) is older than 1 s, source 8 (10.5) is not.
  EXPECT_EQ(map.expire(11.3), 1u);
  EXPECT_EQ(map.counters().sources_evicted_age, 1u);
  std::size_t active = 0;
  for (const MapSourceInfo& s : map.sources()) active += s.active;
  EXPECT_EQ(active, 1u);
  FixedVector<Vec3f, 65536>* out = new FixedVector<Vec3f, 65536>();
  const MapExtractResult e = map.extract(*out);
  // One source left; re-gridding (origin at the merged min bound) merges a few neighbours.
  EXPECT_LE(e.points, map.point_count());
  EXPECT_GT(e.points, 0.95 * map.point_count());
  delete out;
}

// Agents fill gaps: where a trusted (infrastructure) source already sees, an agent's points are
// dropped and counted; elsewhere they are kept; agent_fill_cell = 0 keeps every agent point.
TEST(MapFusion, AgentPointsOnlyWhereTheInfrastructureDoesNotSee) {
  const auto scene = corner_scene();
  std::vector<Vec3d> near_half;  // the infrastructure sees x < 5 m: most of two of three planes
  for (const Vec3d& p : scene) {
    if (p.x() < 5.0) near_half.push_back(p);
  }
  const Mat4d infra = sensor_pose(2.0, 2.0, 0.5);
  const Mat4d agent = sensor_pose(8.0, 3.0, 1.0);
  std::uint32_t agent_all = 0;
  for (const double cell : {0.0, 0.5}) {
    MapFusionParams params;
    params.agent_fill_cell = cell;
    MapFusion& map = fresh_map(params);
    ASSERT_EQ(map.insert(1, 1.0, Pose3d(infra), in_sensor_frame(near_half, infra), true).status,
              MapInsertStatus::kInserted);
    const std::size_t infra_points = map.point_count();
    const MapInsertResult r = map.insert(2, 1.0, Pose3d(agent), in_sensor_frame(scene, agent), false);
    ASSERT_EQ(r.status, MapInsertStatus::kInserted);
    EXPECT_EQ(map.point_count(), infra_points + r.stored_points);
    EXPECT_EQ(map.counters().agent_points_covered, r.covered_dropped);
    if (cell == 0.0) {
      EXPECT_EQ(r.covered_dropped, 0u);
      agent_all = r.stored_points;
    } else {
      EXPECT_GT(r.covered_dropped, 0u);
      EXPECT_EQ(r.stored_points + r.covered_dropped, agent_all);
      // Kept: the far halves of the wall and the ground (x >= 5 m), about a third of the scene.
      EXPECT_LT(r.stored_points, agent_all / 2);
      EXPECT_GT(r.stored_points, agent_all / 5);
      // A trusted source is never thinned by the agent's presence.
      EXPECT_EQ(map.insert(1, 2.0, Pose3d(infra), in_sensor_frame(near_half, infra), true).covered_dropped, 0u);
    }
  }
}

TEST(MapFusion, InconsistentSourceRejected) {
  MapFusion& map = fresh_map();
  const auto scene = corner_scene();
  const Mat4d pose_a = sensor_pose(12.0, 12.0, 2.0);
  ASSERT_EQ(map.insert(1, 0.0, Pose3d(pose_a), in_sensor_frame(scene, pose_a), true).status,
            MapInsertStatus::kInserted);
  // Agent claims a pose 1.5 m / 0.5 m up / 5 deg off its true one: its cloud lands beside the map.
  const Mat4d true_pose = sensor_pose(3.0, 20.0, -1.0);
  Mat4d claimed = true_pose;
  claimed(0, 3) += 1.5;
  claimed(2, 3) += 0.5;
  claimed.topLeftCorner<3, 3>() = rot_z(-1.0 + 0.087);
  const auto r = map.insert(2, 0.1, Pose3d(claimed), in_sensor_frame(scene, true_pose));
  std::printf("inconsistent source: fitness %.3f over %u overlap points\n", r.consistency_fitness,
              r.overlap_points);
  EXPECT_EQ(r.status, MapInsertStatus::kRejectedInconsistent);
  EXPECT_LT(r.consistency_fitness, 0.5);
  EXPECT_EQ(map.counters().rejected_inconsistent, 1u);
}

TEST(MapFusion, CapacityAndSourceSlotOverflowCounted) {
  MapFusionParams params;
  params.check_consistency = false;
  params.voxel_size = 0.2;
  params.max_coarsen_steps = 0;  // cut, not re-voxelised (FullMapSharedEvenlyBetweenSources, below)
  params.max_input_points = 0;   // every input point staged (InputOverTheLimitReadWithAStride, below)
  MapFusion& map = fresh_map(params);
  // One flat cloud larger than the map: 0.2 m grid over N x N cells.
  const int n = static_cast<int>(std::sqrt(double(config::kMaxMapPoints))) + 20;
  std::vector<Vec3f> big;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) big.emplace_back(0.2f * i + 0.1f, 0.2f * j + 0.1f, 0.0f);
  big.emplace_back(NAN, 0.0f, 0.0f);
  const auto r = map.insert(1, 0.0, Pose3d(Mat4d::Identity()), big);
  EXPECT_EQ(r.non_finite_dropped, 1u);
  EXPECT_EQ(map.point_count(), config::kMaxMapPoints);
  EXPECT_EQ(r.stored_points + r.capacity_dropped, static_cast<std::uint32_t>(n * n));
  EXPECT_GT(map.counters().points_dropped_capacity, 0u);
  // Source slots per role: half infrastructure, half agents. At the agent cap a newer agent
  // displaces the oldest agent, an older one is refused; no agent ever displaces infrastructure.
  map.clear();
  std::vector<Vec3f> small = {Vec3f(0, 0, 0), Vec3f(1, 0, 0)};
  const std::uint32_t half = config::kMaxMapSources / 2;
  for (std::uint32_t s = 0; s < half; ++s)
    EXPECT_EQ(map.insert(1 + s, 0.5, Pose3d(Mat4d::Identity()), small, true).status, MapInsertStatus::kInserted);
  for (std::uint32_t s = 0; s < half; ++s)
    EXPECT_EQ(map.insert(100 + s, 1.0 + s, Pose3d(Mat4d::Identity()), small).status, MapInsertStatus::kInserted);
  EXPECT_EQ(map.insert(999, 0.7, Pose3d(Mat4d::Identity()), small).status, MapInsertStatus::kNoSourceSlot);
  EXPECT_EQ(map.insert(1000, 50.0, Pose3d(Mat4d::Identity()), small).status, MapInsertStatus::kInserted);
  EXPECT_EQ(map.counters().sources_evicted_slot, 1u);
  EXPECT_EQ(map.counters().no_source_slot, 1u);
  bool oldest_agent_present = false;
  std::uint32_t infra_present = 0;
  for (const MapSourceInfo& s : map.sources()) {
    oldest_agent_present |= s.active && s.id == 100;
    infra_present += (s.active && s.trusted) ? 1u : 0u;
  }
  EXPECT_FALSE(oldest_agent_present);
  EXPECT_EQ(infra_present, half);
  // Invented agent ids, all newer than the infrastructure: they only churn the agent slots.
  for (std::uint32_t s = 0; s < 16; ++s) map.insert(5000 + s, 100.0 + s, Pose3d(Mat4d::Identity()), small);
  infra_present = 0;
  for (const MapSourceInfo& s : map.sources()) infra_present += (s.active && s.trusted) ? 1u : 0u;
  EXPECT_EQ(infra_present, half);
}

// Share of a full map: every source gets capacity / sources, the earlier ones thinned evenly to
// make room (not the first source whole and the later ones nothing); all drops counted.
TEST(MapFusion, FullMapSharedEvenlyBetweenSources) {
  MapFusionParams params;
  params.check_consistency = false;
  params.voxel_size = 0.2;
  params.max_points = 300;
  MapFusion& map = fresh_map(params);
  // Three flat 0.2 m grids of 400 points each, apart (one voxel per point).
  auto grid = [](float x0) {
    std::vector<Vec3f> g;
    for (int i = 0; i < 20; ++i)
      for (int j = 0; j < 20; ++j) g.emplace_back(x0 + 0.2f * i + 0.1f, 0.2f * j + 0.1f, 0.0f);
    return g;
  };
  const Pose3d id(Mat4d::Identity());
  auto r = map.insert(1, 0.0, id, grid(0.0f), true);
  EXPECT_EQ(r.stored_points, 300u);  // alone: the whole capacity
  EXPECT_EQ(r.capacity_dropped, 100u);
  r = map.insert(2, 0.0, id, grid(10.0f), true);
  EXPECT_EQ(r.stored_points, 150u);
  EXPECT_EQ(r.share_trimmed, 150u);  // source 1 thinned to its half
  r = map.insert(3, 0.0, id, grid(20.0f), true);
  EXPECT_EQ(r.stored_points, 100u);
  EXPECT_EQ(r.share_trimmed, 100u);  // 1 and 2 thinned to a third each
  EXPECT_EQ(map.point_count(), 300u);
  std::uint32_t per_source[4] = {};
  for (const MapSourceInfo& s : map.sources()) {
    if (s.active) per_source[s.id] = s.points;
  }
  EXPECT_EQ(per_source[1], 100u);
  EXPECT_EQ(per_source[2], 100u);
  EXPECT_EQ(per_source[3], 100u);
  // Kept evenly: the thinned source still spans its whole grid.
  FixedVector<Vec3f, 1024> out;
  map.extract(out);
  float lo = 1e9f, hi = -1e9f;
  for (const Vec3f& p : out) {
    if (p.x() < 5.0f) {
      lo = std::min(lo, p.y());
      hi = std::max(hi, p.y());
    }
  }
  EXPECT_LT(lo, 0.5f);
  EXPECT_GT(hi, 3.5f);
  // A replacement frees the source's points first: it gets its share back, nothing thinned.
  r = map.insert(1, 1.0, id, grid(0.0f), true);
  EXPECT_EQ(r.status, MapInsertStatus::kReplaced);
  EXPECT_EQ(r.stored_points, 100u);
  EXPECT_EQ(r.share_trimmed, 0u);
  EXPECT_EQ(map.point_count(), 300u);
  EXPECT_EQ(map.counters().points_trimmed_share, 250u);
  EXPECT_EQ(map.counters().points_dropped_capacity, 100u + 250u + 300u + 300u);
}

// A cloud with more voxels than the map holds is downsampled again with the voxel doubled, not
// cut in scan order: nothing dropped, and it spans its whole extent.
TEST(MapFusion, CloudOverTheCapacityIsCoarsenedNotCut) {
  // Host: the staging buffer holds no more points than the map, so no cloud overflows it.
  if (config::kMaxMapInputPoints <= config::kMaxMapPoints) GTEST_SKIP() << "needs more staged than map points (EMBEDDED)";
  MapFusionParams params;
  params.check_consistency = false;
  params.voxel_size = 0.2;
  params.max_input_points = 0;
  MapFusion& map = fresh_map(params);
  // A 0.2 m grid of more voxels than the map holds, every point staged.
  const int n = std::min(static_cast<int>(std::sqrt(double(config::kMaxMapPoints))) + 20,
                         static_cast<int>(std::sqrt(double(config::kMaxMapInputPoints))));
  ASSERT_GT(static_cast<std::size_t>(n * n), config::kMaxMapPoints);
  std::vector<Vec3f> big;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) big.emplace_back(0.2f * i + 0.1f, 0.2f * j + 0.1f, 0.0f);
  const auto r = map.insert(1, 0.0, Pose3d(Mat4d::Identity()), big, true);
  EXPECT_EQ(r.coarsened, 1u);  // 0.4 m: a quarter of the voxels
  EXPECT_EQ(r.capacity_dropped, 0u);
  EXPECT_GE(r.stored_points, static_cast<std::uint32_t>(((n + 1) / 2) * ((n + 1) / 2)));  // ~n/2 cells a side
  EXPECT_LE(r.stored_points, static_cast<std::uint32_t>(((n + 3) / 2) * ((n + 3) / 2)));  // (grid phase)
  EXPECT_EQ(map.counters().clouds_coarsened, 1u);
  static FixedVector<Vec3f, config::kMaxMapPoints> out;
  map.extract(out);
  float hi = -1e9f;
  for (const Vec3f& p : out) hi = std::max(hi, p.y());
  EXPECT_GT(hi, 0.2f * static_cast<float>(n) - 0.5f);  // the last rows are kept
}

// A cloud of more than max_input_points is read with an even stride before staging (its cost is
// linear in the points read), counted; it still spans its whole extent.
TEST(MapFusion, InputOverTheLimitReadWithAStride) {
  MapFusionParams params;
  params.check_consistency = false;
  params.voxel_size = 0.2;
  params.max_input_points = 1000;
  MapFusion& map = fresh_map(params);
  std::vector<Vec3f> line;
  for (int i = 0; i < 2500; ++i) line.emplace_back(0.05f * i, 0.0f, 0.0f);  // 125 m, 4 points a voxel
  const auto r = map.insert(1, 0.0, Pose3d(Mat4d::Identity()), line, true);
  EXPECT_EQ(r.input_points, 2500u);
  EXPECT_EQ(r.input_thinned, 2500u - 834u);  // stride 3: points 0, 3, ..., 2499
  EXPECT_EQ(map.counters().input_points_thinned, 2500u - 834u);
  EXPECT_EQ(r.capacity_dropped, 0u);
  EXPECT_GE(r.stored_points, 600u);  // 834 points 0.15 m apart in 0.2 m voxels
  static FixedVector<Vec3f, config::kMaxMapPoints> out;
  map.extract(out);
  float hi = -1e9f;
  for (const Vec3f& p : out) hi = std::max(hi, p.x());
  EXPECT_GT(hi, 124.0f);  // the end of the line is kept
  // At or under the limit: nothing skipped.
  line.resize(1000);
  const auto small = map.insert(2, 0.0, Pose3d(Mat4d::Identity()), line, true);
  EXPECT_EQ(small.input_thinned, 0u);
  // A limit above the staging's capacity is held to it: the cloud is strided, not cut.
  MapFusionParams roomy = params;
  roomy.max_input_points = 4 * static_cast<std::uint32_t>(config::kMaxMapInputPoints);
  MapFusion& wide = fresh_map(roomy);
  std::vector<Vec3f> long_line;
  const std::size_t n = 2 * config::kMaxMapInputPoints;
  for (std::size_t i = 0; i < n; ++i) long_line.emplace_back(125.0f * static_cast<float>(i) / static_cast<float>(n), 0.0f, 0.0f);
  const auto strided = wide.insert(1, 0.0, Pose3d(Mat4d::Identity()), long_line, true);
  EXPECT_EQ(strided.input_thinned, n / 2);
  EXPECT_EQ(strided.capacity_dropped, 0u);
  wide.extract(out);
  hi = -1e9f;
  for (const Vec3f& p : out) hi = std::max(hi, p.x());
  EXPECT_GT(hi, 124.0f);
}

// Consistency before trust: an agent shifted by as little as 0.25 m fits the infrastructure better
// displaced back (shift probe) and is rejected; one shifted out of the overlap entirely cannot be
// checked and is held back, not accepted with fitness 1.
TEST(MapFusion, ShiftedAgentRejectedAndUncheckableAgentHeldBack) {
  const auto scene = corner_scene();
  const Mat4d infra = sensor_pose(12.0, 12.0, 2.0);
  const Mat4d agent = sensor_pose(-5.0, 15.0, -0.7);
  for (const double shift : {0.0, 0.25, 3.0, 200.0}) {
    MapFusion& map = fresh_map();
    ASSERT_EQ(map.insert(1, 1.0, Pose3d(infra), in_sensor_frame(scene, infra), true).status, MapInsertStatus::kInserted);
    Mat4d claimed = agent;
    claimed(0, 3) += shift;
    const MapInsertResult r = map.insert(40, 1.0, Pose3d(claimed), in_sensor_frame(scene, agent));
    std::printf("agent shifted %.2f m: fitness %.3f, best probe %.3f, overlap %u -> status %d\n", shift,
                r.consistency_fitness, r.best_probe_fitness, r.overlap_points, static_cast<int>(r.status));
    if (shift == 0.0) {
      EXPECT_EQ(r.status, MapInsertStatus::kInserted);
    } else if (shift > 100.0) {
      EXPECT_EQ(r.status, MapInsertStatus::kHeldBack);
      EXPECT_EQ(map.counters().held_back, 1u);
    } else {
      EXPECT_EQ(r.status, MapInsertStatus::kRejectedInconsistent);
    }
  }
  // Without any infrastructure in the map an agent cannot be checked: held back.
  MapFusion& map = fresh_map();
  EXPECT_EQ(map.insert(40, 1.0, Pose3d(agent), in_sensor_frame(scene, agent)).status, MapInsertStatus::kHeldBack);
}

// Infrastructure quorum: a unit whose points are shifted under its true pose (what the survey check
// cannot see) is outvoted by three other units (counted), whatever the shift; against one other unit
// it is not (two units cannot outvote each other: a 3 m shift leaves no peak to compare).
TEST(MapFusion, ShiftedInfrastructureOutvotedByThreeUnitsNotByOne) {
  const auto scene = corner_scene();
  const auto units = intersection_units();
  for (const double shift : {0.0, 0.25, 3.0}) {
    for (const std::size_t others : {std::size_t{1}, std::size_t{3}}) {
      MapFusion& map = fresh_map();
      for (std::size_t k = 0; k < others; ++k) ASSERT_EQ(insert_genuine_unit(map, scene, units, k), MapInsertStatus::kInserted);
      const std::vector<Vec3d> moved = moved_along_x(scene, shift);
      const MapInsertResult r = map.insert(9, 1.0, Pose3d(units[3]), in_sensor_frame(moved, units[3]), true);
      const bool outvoted = shift > 0.0 && others == 3;
      EXPECT_EQ(r.status, outvoted ? MapInsertStatus::kRejectedInconsistent : MapInsertStatus::kInserted)
          << "shift " << shift << " others " << others << " fitness " << r.consistency_fitness << " probe "
          << r.best_probe_fitness;
      EXPECT_EQ(map.counters().infra_outvoted, outvoted ? 1u : 0u);
      EXPECT_EQ(r.outvoted, outvoted);
    }
  }
}

// A unit whose points are moved out of all overlap (200 m under its true pose) cannot be scored:
// facing two or more other units it is held back (its older cloud evicted, counted), and a rogue
// that sent first is evicted once three genuine units are there to vet it. Against one other unit
// it is accepted: two units cannot tell which of them is out of place.
TEST(MapFusion, InfrastructureOutOfAllOverlapHeldBackByAQuorum) {
  const auto scene = corner_scene();
  const auto units = intersection_units();
  const std::vector<Vec3d> far = moved_along_x(scene, 200.0);
  for (const std::size_t others : {std::size_t{1}, std::size_t{2}, std::size_t{3}}) {
    MapFusion& map = fresh_map();
    for (std::size_t k = 0; k < others; ++k) ASSERT_EQ(insert_genuine_unit(map, scene, units, k), MapInsertStatus::kInserted);
    const MapInsertResult r = map.insert(9, 1.0, Pose3d(units[3]), in_sensor_frame(far, units[3]), true);
    EXPECT_EQ(r.overlap_points, 0u);
    EXPECT_EQ(r.status, others >= 2 ? MapInsertStatus::kHeldBack : MapInsertStatus::kInserted) << others;
    EXPECT_EQ(map.counters().infra_unchecked, others >= 2 ? 1u : 0u);
  }
  MapFusion& map = fresh_map();  // the rogue first: accepted, then vetted out by three genuine units
  ASSERT_EQ(map.insert(9, 1.0, Pose3d(units[3]), in_sensor_frame(far, units[3]), true).status, MapInsertStatus::kInserted);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(insert_genuine_unit(map, scene, units, k), MapInsertStatus::kInserted) << k;
  EXPECT_EQ(map.counters().infra_evicted, 1u);
  for (const MapSourceInfo& s : map.sources()) EXPECT_FALSE(s.active && s.id == 9);
}

// The first unit to send is checked against nothing: a rogue that arrives first is accepted, the
// genuine units after it are not rejected for disagreeing with it, and once three other units are
// present its stored cloud is vetted against them and evicted; its next cloud is outvoted.
TEST(MapFusion, RogueArrivingFirstIsEvictedOnceOutvoted) {
  const auto scene = corner_scene();
  const auto units = intersection_units();
  const std::vector<Vec3d> moved = moved_along_x(scene, 3.0);
  MapFusion& map = fresh_map();
  ASSERT_EQ(map.insert(9, 1.0, Pose3d(units[3]), in_sensor_frame(moved, units[3]), true).status, MapInsertStatus::kInserted);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(insert_genuine_unit(map, scene, units, k), MapInsertStatus::kInserted) << k;
  EXPECT_EQ(map.counters().infra_evicted, 1u);
  std::uint32_t genuine = 0;
  for (const MapSourceInfo& s : map.sources()) {
    EXPECT_FALSE(s.active && s.id == 9u);
    genuine += s.active ? 1u : 0u;
  }
  EXPECT_EQ(genuine, 3u);
  const MapInsertResult r = map.insert(9, 1.5, Pose3d(units[3]), in_sensor_frame(moved, units[3]), true);
  EXPECT_EQ(r.status, MapInsertStatus::kRejectedInconsistent);
  EXPECT_TRUE(r.outvoted);
}

// The check scores an even subsample of a large cloud: the same verdicts as scoring every point,
// and the overlap count scaled back to the whole cloud.
TEST(MapFusion, SampledConsistencyKeepsTheVerdicts) {
  const auto scene = corner_scene();
  const Mat4d infra = sensor_pose(12.0, 12.0, 2.0);
  const Mat4d agent = sensor_pose(-5.0, 15.0, -0.7);
  for (const double shift : {0.0, 0.25, 3.0}) {
    MapInsertResult full, sampled;
    for (const std::uint32_t cap : {0u, 300u}) {  // 0: the config cap (more than the cloud)
      MapFusionParams p;
      p.max_consistency_points = cap;
      MapFusion& map = fresh_map(p);
      ASSERT_EQ(map.insert(1, 1.0, Pose3d(infra), in_sensor_frame(scene, infra), true).status, MapInsertStatus::kInserted);
      Mat4d claimed = agent;
      claimed(0, 3) += shift;
      (cap == 0 ? full : sampled) = map.insert(40, 1.0, Pose3d(claimed), in_sensor_frame(scene, agent));
    }
    ASSERT_GT(full.overlap_points, 1000u);  // the subsample really is one (stride > 3)
    EXPECT_EQ(sampled.status, full.status) << "shift " << shift;
    EXPECT_NEAR(sampled.consistency_fitness, full.consistency_fitness, 0.05) << "shift " << shift;
    EXPECT_NEAR(static_cast<double>(sampled.overlap_points), static_cast<double>(full.overlap_points),
                0.1 * full.overlap_points);
  }
}

}  // namespace
}  // namespace v2xloc
