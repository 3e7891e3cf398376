#include "v2xloc/algo/localization/reference_map.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

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

// A source's clouds closer than map_cloud_interval to its stored one are not fused (the rebuild
// would take a later one); wants() says so beforehand; a new source, a later cloud and a stale
// one take their usual paths.
TEST(ReferenceMap, CloudsWithinTheIntervalOfTheSourcesLastArePaced) {
  auto map = std::make_unique<ReferenceMap>();
  LocalizerParams params;
  params.map_cloud_interval = 0.9;
  map->configure(params);
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

  params.map_cloud_interval = 0.0;  // off: every newer cloud is fused
  map->configure(params);
  EXPECT_EQ(map->insert(cloud(7, 1.0, points)).status, MapInsertStatus::kInserted);
  EXPECT_EQ(map->insert(cloud(7, 1.01, points)).status, MapInsertStatus::kReplaced);
}

}  // namespace
}  // namespace v2xloc
