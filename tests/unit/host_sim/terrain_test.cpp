// The sloped ground (host_sim/world/terrain.hpp): heights and normals of the grade and the crown,
// rays that find the ground where its height says, vehicle poses on it, and a draped world whose
// buildings stand on it; a flat terrain casts like the plane z = 0.
#include <gtest/gtest.h>

#include <cmath>

#include "host_sim/scenario/scenario.hpp"
#include "host_sim/world/intersection_world.hpp"
#include "host_sim/world/terrain.hpp"

namespace v2xloc::sim {
namespace {

Terrain hillside() {
  Terrain t;
  t.grade = 0.05;
  t.grade_heading = 0.3;
  t.crown = 0.02;
  return t;
}

TEST(Terrain, HeightIsTheGradePlusTheCrown) {
  const Terrain t = hillside();
  const double along = 40.0 * std::cos(0.3) + 1.75 * std::sin(0.3);
  EXPECT_NEAR(t.height(40.0, 1.75), 0.05 * along - 0.02 * 1.75, 1e-12);   // E-W road, inner lane
  EXPECT_NEAR(t.height(40.0, 30.0), 0.05 * (40.0 * std::cos(0.3) + 30.0 * std::sin(0.3)) - 0.02 * 7.0, 1e-12);
  const Eigen::Vector3d n = t.normal(40.0, 1.75);
  const double h = 1e-6;
  const double dx = (t.height(40.0 + h, 1.75) - t.height(40.0 - h, 1.75)) / (2 * h);
  const double dy = (t.height(40.0, 1.75 + h) - t.height(40.0, 1.75 - h)) / (2 * h);
  EXPECT_NEAR(n.x() / n.z(), -dx, 1e-6);
  EXPECT_NEAR(n.y() / n.z(), -dy, 1e-6);
}

TEST(Terrain, RaysMeetTheGroundAtItsHeight) {
  const Terrain t = hillside();
  int hits = 0;
  for (int k = 0; k < 200; ++k) {
    const double az = 0.031 * k, el = -0.02 - 0.002 * k;
    const Eigen::Vector3d origin(-30.0, 1.75, t.height(-30.0, 1.75) + 1.8);
    const Eigen::Vector3d dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    double range = 0.0;
    if (!t.intersect(origin, dir, 200.0, range)) continue;
    ++hits;
    const Eigen::Vector3d p = origin + range * dir;
    EXPECT_NEAR(p.z(), t.height(p.x(), p.y()), 2e-4) << k;
  }
  EXPECT_GT(hits, 150);
  double range = 0.0;  // a ray that climbs faster than the ground never meets it
  EXPECT_FALSE(t.intersect(Eigen::Vector3d(0, 0, 2), Eigen::Vector3d(1, 0, 0.1).normalized(), 500.0, range));
}

TEST(Terrain, FlatTerrainIsThePlaneZZero) {
  const Terrain flat;
  double range = 0.0;
  ASSERT_TRUE(flat.intersect(Eigen::Vector3d(0, 0, 2), Eigen::Vector3d(0.6, 0, -0.8), 100.0, range));
  EXPECT_EQ(range, -2.0 / -0.8);
  const Eigen::Isometry3d pose = flat.vehicle_pose(3.0, 4.0, 0.5);
  EXPECT_EQ(pose.translation(), Eigen::Vector3d(3.0, 4.0, 0.0));
  EXPECT_TRUE(pose.linear().isApprox(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix()));
}

TEST(Terrain, VehiclesPitchWithTheGradeAndRollWithTheCrown) {
  Terrain t;
  t.grade = 0.05;   // rising east
  t.crown = 0.02;
  const Eigen::Isometry3d east = t.vehicle_pose(-40.0, -1.75, 0.0);  // eastbound, right of the axis
  EXPECT_NEAR(east.linear()(2, 0), 0.05 / std::sqrt(1.0 + 0.05 * 0.05), 1e-9);  // nose up 2.86 deg
  // Right of the E-W axis the road falls to the south (away from the axis): the left side is higher.
  EXPECT_NEAR(east.linear()(2, 1), 0.02, 1e-3);
  EXPECT_NEAR(east.translation().z(), t.height(-40.0, -1.75), 1e-9);
  const Eigen::Isometry3d west = t.vehicle_pose(40.0, 1.75, M_PI);
  EXPECT_LT(west.linear()(2, 0), -0.049);  // westbound: downhill
}

TEST(Terrain, DrapedWorldStandsOnTheGround) {
  WorldConfig cfg;
  cfg.seed = 5;
  cfg.terrain = hillside();
  IntersectionWorld iw;
  build_intersection_world(cfg, iw);
  // Straight down from 60 m everywhere on a grid: the first hit is never below the ground, and on
  // the roads it is the ground itself.
  int road_hits = 0;
  for (double x = -120.0; x <= 120.0; x += 7.3) {
    for (double y = -120.0; y <= 120.0; y += 7.9) {
      RayHit hit;
      const Eigen::Vector3d origin(x, y, 80.0);
      ASSERT_TRUE(iw.world.cast(origin, Eigen::Vector3d(0, 0, -1), 200.0, hit));
      const double z = 80.0 - hit.range;
      EXPECT_GE(z, cfg.terrain.height(x, y) - 1e-3) << x << " " << y;
      if (hit.object_id == 0) {
        ++road_hits;
        EXPECT_NEAR(z, cfg.terrain.height(x, y), 2e-4);
      }
    }
  }
  EXPECT_GT(road_hits, 100);
  // The infrastructure units stand 5 m above the ground under them.
  for (const InfraSite& s : infra_sites(Permutation::k4Infra, cfg.terrain)) {
    const Eigen::Vector3d p = s.sensor_to_enu.translation();
    EXPECT_NEAR(p.z() - cfg.terrain.height(p.x(), p.y()), 5.0, 1e-9);
  }
}

}  // namespace
}  // namespace v2xloc::sim
