#include "v2xloc/algo/localization/reference_map.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "v2xloc/algo/localization/localizer_params.hpp"

namespace v2xloc {
namespace {

std::vector<Vec3f> wall() {
  std::vector<Vec3f> pts;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 20; ++j) pts.emplace_back(0.2f * static_cast<float>(i), 5.0f, 0.2f * static_cast<float>(j));
  return pts;
}

MapCloudInput cloud(std::uint32_t id, double t, const std::vector<Vec3f>& points) {
  MapCloudInput in;
  in.source_id = id;
  in.t = t;
  in.is_agent = false;
  in.world_T_sensor = Pose3d::Identity();
  in.points = points;
  return in;
}

// A reference map (static storage: on the heap in tests) pacing each source to `interval`.
std::unique_ptr<ReferenceMap> paced_map(double interval) {
  auto map = std::make_unique<ReferenceMap>();
  LocalizerParams params;
  params.map.cloud_interval = interval;
  map->configure(params.map, params.tracking.icp.max_correspondence_distance);
  return map;
}

// A source's clouds closer than map.cloud_interval to its stored one are not fused (the rebuild
// would take a later one); wants() says so beforehand; a new source, a later cloud and a stale
// one take their usual paths.
TEST(ReferenceMap, CloudsWithinTheIntervalOfTheSourcesLastArePaced) {
  auto map = paced_map(0.9);
  const std::vector<Vec3f> points = wall();

  EXPECT_TRUE(map->wants(7, 1.0));
  EXPECT_EQ(map->insert(cloud(7, 1.0, points)).status, MapInsertStatus::kInserted);
  EXPECT_FALSE(map->wants(7, 1.5));
  const MapInsertResult paced = map->insert(cloud(7, 1.5, points));
  EXPECT_EQ(paced.status, MapInsertStatus::kPaced);
  EXPECT_EQ(paced.input_points, points.size());
  EXPECT_EQ(map->fusion().sources()[0].timestamp, 1.0);
  EXPECT_TRUE(map->wants(8, 1.5)) << "another source";
  EXPECT_TRUE(map->wants(7, 0.5)) << "stale: map fusion refuses it and counts it";
  EXPECT_EQ(map->insert(cloud(7, 0.5, points)).status, MapInsertStatus::kStale);
  EXPECT_TRUE(map->wants(7, 1.95));
  EXPECT_EQ(map->insert(cloud(7, 1.95, points)).status, MapInsertStatus::kReplaced);

  map = paced_map(0.0);  // off: every newer cloud is fused
  EXPECT_EQ(map->insert(cloud(7, 1.0, points)).status, MapInsertStatus::kInserted);
  EXPECT_EQ(map->insert(cloud(7, 1.01, points)).status, MapInsertStatus::kReplaced);
}

// A source whose clouds are refused (here an agent with no infrastructure to be checked against:
// held back) is paced on its last attempt: one consistency check per interval, not one per share.
TEST(ReferenceMap, RefusedSourcesArePacedOnTheirLastAttempt) {
  auto map = paced_map(0.9);
  const std::vector<Vec3f> points = wall();
  MapCloudInput agent = cloud(40, 1.0, points);
  agent.is_agent = true;
  EXPECT_EQ(map->insert(agent).status, MapInsertStatus::kHeldBack);
  EXPECT_FALSE(map->wants(40, 1.5));
  EXPECT_FALSE(map->wants(40, 0.8)) << "older than its last attempt";
  agent.t = 1.5;
  EXPECT_EQ(map->insert(agent).status, MapInsertStatus::kPaced);
  EXPECT_TRUE(map->wants(40, 2.0));
  agent.t = 2.0;
  EXPECT_EQ(map->insert(agent).status, MapInsertStatus::kHeldBack);
  // Many other ids cannot make it forget a source for long: the table keeps the newest attempts.
  for (std::uint32_t id = 100; id < 100 + 2 * config::kMaxMapSources - 1; ++id) {
    MapCloudInput other = cloud(id, 2.1, points);
    other.is_agent = true;
    map->insert(other);
  }
  EXPECT_FALSE(map->wants(40, 2.5));
}

// refresh() closes a period: busy() tells whether clouds were fused since the previous one. A due
// rebuild waits for a period without clouds (the end of a burst), at most map.refresh_quiet_wait.
TEST(ReferenceMap, DueRebuildWaitsForAQuietPeriodButNotForever) {
  auto map = std::make_unique<ReferenceMap>();
  LocalizerParams params;
  params.map.cloud_interval = 0.0;
  params.map.refresh_period = 1.0;
  params.map.refresh_quiet_wait = 0.5;
  map->configure(params.map, params.tracking.icp.max_correspondence_distance);
  const std::vector<Vec3f> points = wall();
  LazyNormalCounters normals;

  ASSERT_EQ(map->insert(cloud(1, 0.0, points)).status, MapInsertStatus::kInserted);
  EXPECT_TRUE(map->refresh(0.0, normals)) << "the first map is built at once";
  EXPECT_TRUE(map->busy());
  EXPECT_FALSE(map->refresh(0.1, normals));
  EXPECT_FALSE(map->busy());

  // Due at 1.0 s, but clouds keep arriving: no rebuild starts while they do ...
  double t = 1.0;
  for (; t < 1.35; t += 0.1) {
    ASSERT_EQ(map->insert(cloud(1, t, points)).status, MapInsertStatus::kReplaced);
    EXPECT_FALSE(map->refresh(t, normals)) << t;
    EXPECT_TRUE(map->busy());
  }
  // ... the first quiet period starts it (extract, then the tree: finished a period later).
  EXPECT_FALSE(map->refresh(t, normals));
  EXPECT_FALSE(map->busy());
  EXPECT_TRUE(map->refresh(t + 0.1, normals));

  // A source sending every period: the rebuild starts once the wait is over (1.5 s after the last).
  const double built = t;
  bool rebuilt = false;
  double finished_at = 0.0;
  for (t = built + 0.2; t < built + 2.2 && !rebuilt; t += 0.1) {
    ASSERT_EQ(map->insert(cloud(1, t, points)).status, MapInsertStatus::kReplaced);
    rebuilt = map->refresh(t, normals);
    finished_at = t;
  }
  EXPECT_TRUE(rebuilt);
  EXPECT_GE(finished_at, built + 1.5);
  EXPECT_LE(finished_at, built + 1.75);
}

}  // namespace
}  // namespace v2xloc
