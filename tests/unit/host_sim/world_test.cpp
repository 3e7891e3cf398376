#include "host_sim/world/intersection_world.hpp"
#include "host_sim/world/world.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace v2xloc::sim {
namespace {

TEST(HostSimWorld, RayAgainstBoxPlaneCylinderSphereReturnsTrueRange) {
  World w;
  w.add(Primitive::box({10, -5, 0}, {12, 5, 10}, kMatBuilding, w.new_object_id()));
  w.add(Primitive::cylinder(0, 20, 0, 5, 0.5, kMatPole, w.new_object_id()));
  w.add(Primitive::sphere({-30, 0, 3}, 2.0, kMatFoliage, w.new_object_id()));
  w.add(Primitive::yaw_box({0, -20, 1}, {2, 1, 1}, M_PI / 4, kMatParkedCar, w.new_object_id()));
  w.build();
  RayHit hit;
  const Eigen::Vector3d o(0, 0, 2);
  ASSERT_TRUE(w.cast(o, Eigen::Vector3d::UnitX(), 100, hit));
  EXPECT_NEAR(hit.range, 10.0, 1e-12);
  EXPECT_EQ(hit.material, kMatBuilding);
  EXPECT_NEAR(hit.normal.x(), -1.0, 1e-12);
  // Oblique ray to the same face: range = 10 / cos(20 deg).
  const double a = 20.0 * M_PI / 180.0;
  const Eigen::Vector3d d(std::cos(a), std::sin(a), 0);
  ASSERT_TRUE(w.cast(o, d, 100, hit));
  EXPECT_NEAR(hit.range, 10.0 / std::cos(a), 1e-12);
  ASSERT_TRUE(w.cast(o, Eigen::Vector3d::UnitY(), 100, hit));
  EXPECT_NEAR(hit.range, 19.5, 1e-12);
  ASSERT_TRUE(w.cast(o, -Eigen::Vector3d::UnitX(), 100, hit));
  EXPECT_NEAR(hit.range, 30.0 - std::sqrt(3.0), 1e-12);  // 1 m below the sphere centre
  // Box rotated 45 deg: along its centre's x = 0 line the boundary is where local u = v = 1,
  // i.e. sqrt(2) from the centre.
  ASSERT_TRUE(w.cast(Eigen::Vector3d(0, 0, 1), -Eigen::Vector3d::UnitY(), 100, hit));
  EXPECT_NEAR(hit.range, 20.0 - std::sqrt(2.0), 1e-9);
  // Ground plane.
  const Eigen::Vector3d down = Eigen::Vector3d(1, 0, -1).normalized();
  ASSERT_TRUE(w.cast(o, down, 100, hit));
  EXPECT_NEAR(hit.range, 2.0 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(hit.normal.z(), 1.0, 1e-12);
  // Max range respected; pointing at the sky misses.
  EXPECT_FALSE(w.cast(o, Eigen::Vector3d::UnitX(), 9.0, hit));
  EXPECT_FALSE(w.cast(o, Eigen::Vector3d::UnitZ(), 100, hit));
}

TEST(HostSimWorld, DynamicBodiesOccludeAndCanBeExcluded) {
  World w;
  w.set_ground_plane(false);
  w.build();
  const int body = w.add_dynamic_body(make_car_body("car", [](double t) { return PlanarPose{10.0 + t, 0.0, 0.0}; }));
  RayHit hit;
  const DynamicSnapshot s0 = w.snapshot(0.0), s2 = w.snapshot(2.0);
  ASSERT_TRUE(w.cast(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::UnitX(), 100, hit, s0, -1));
  EXPECT_NEAR(hit.range, 10.0 - 2.3, 1e-12);
  ASSERT_TRUE(w.cast(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::UnitX(), 100, hit, s2, -1));
  EXPECT_NEAR(hit.range, 12.0 - 2.3, 1e-12);
  EXPECT_FALSE(w.cast(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::UnitX(), 100, hit, s2, body));
}

TEST(HostSimWorld, IntersectionIsDeterministicAndHasACanyon) {
  IntersectionWorld a, b, c;
  WorldConfig five, six;
  five.seed = 5;
  six.seed = 6;
  build_intersection_world(five, a);
  build_intersection_world(five, b);
  build_intersection_world(six, c);
  ASSERT_EQ(a.world.primitives().size(), b.world.primitives().size());
  for (std::size_t i = 0; i < a.world.primitives().size(); ++i)
    EXPECT_EQ(a.world.primitives()[i].hi, b.world.primitives()[i].hi);
  EXPECT_NE(a.buildings.front().height, c.buildings.front().height);
  EXPECT_GE(a.buildings.size(), 16u);
  for (const auto& bld : a.buildings) {
    EXPECT_GE(bld.height, 10.0);
    EXPECT_LE(bld.height, 40.0);
    // Nothing built on the roads or sidewalks.
    const bool on_ew = bld.lo.y() < IntersectionLayout::kRoadHalfWidth + 4.0 && bld.hi.y() > -IntersectionLayout::kRoadHalfWidth - 4.0;
    const bool on_ns = bld.lo.x() < IntersectionLayout::kRoadHalfWidth + 4.0 && bld.hi.x() > -IntersectionLayout::kRoadHalfWidth - 4.0;
    EXPECT_FALSE(on_ew || on_ns);
  }
  // Looking up at 30 deg across the street from the road arms mostly hits a facade (canyon).
  int hits = 0;
  for (double x = 30; x <= 100; x += 10) {
    RayHit hit;
    const Eigen::Vector3d dir = Eigen::Vector3d(0, 1, std::tan(M_PI / 6)).normalized();
    hits += a.world.cast(Eigen::Vector3d(x, 0, 1.8), dir, 200, hit) ? 1 : 0;
  }
  EXPECT_GE(hits, 5);
}

}  // namespace
}  // namespace v2xloc::sim
