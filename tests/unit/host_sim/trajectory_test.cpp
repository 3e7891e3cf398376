#include "host_sim/scenario/scenario.hpp"
#include "host_sim/scenario/simulation.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace v2xloc::sim {
namespace {

TEST(HostSimScenario, TrajectoriesAreSmoothAndSpeedsConsistent) {
  for (int id = 0; id < kScenarioCount; ++id) {
    const Scenario sc = make_scenario(id);
    EXPECT_GE(sc.duration, 20.0);
    EXPECT_LE(sc.duration, 40.0);
    ASSERT_EQ(sc.agents.size(), 2u);
    const double h = 1e-4;
    for (double t = 0.0; t < sc.duration; t += 0.37) {
      const VehicleState s = sc.ego.state(t);
      const PlanarPose a = sc.ego.pose(t - h), b = sc.ego.pose(t + h);
      const double v = std::hypot(b.x - a.x, b.y - a.y) / (2 * h);
      EXPECT_NEAR(v, s.speed, 1e-3) << "scenario " << id << " t " << t;
      EXPECT_NEAR(std::remainder(b.yaw - a.yaw, 2 * M_PI) / (2 * h), s.yaw_rate, 1e-3);
      EXPECT_GT(s.speed, 3.0);   // urban speeds
      EXPECT_LT(s.speed, 14.0);
      // The ego stays on the road (inner lanes of the two roads).
      EXPECT_TRUE(std::abs(s.pose.x) < 7.0 || std::abs(s.pose.y) < 7.0);
    }
  }
  // Sim 3: the ego ends up heading west after its left turn; Sim 1: agents stationary.
  const Scenario s3 = make_scenario(3);
  EXPECT_NEAR(std::remainder(s3.ego.pose(s3.duration).yaw - M_PI, 2 * M_PI), 0.0, 1e-9);
  EXPECT_NEAR(std::remainder(s3.agents[0].pose(s3.duration).yaw, 2 * M_PI), 0.0, 1e-9);
  const Scenario s1 = make_scenario(1);
  EXPECT_TRUE(s1.agents[0].is_stationary());
  EXPECT_TRUE(s1.agents[1].is_stationary());
  // Sim 0: agent 0 drives the opposing direction in parallel; Sim 2: perpendicular.
  const Scenario s0 = make_scenario(0), s2 = make_scenario(2);
  EXPECT_NEAR(std::cos(s0.agents[0].pose(1).yaw - s0.ego.pose(1).yaw), -1.0, 1e-9);
  EXPECT_NEAR(std::cos(s2.agents[0].pose(1).yaw - s2.ego.pose(1).yaw), 0.0, 1e-9);
}

TEST(HostSimScenario, InfraSitesPerPermutation) {
  EXPECT_EQ(infra_sites(Permutation::k4Infra2Agent).size(), 4u);
  EXPECT_EQ(infra_sites(Permutation::k4Infra).size(), 4u);
  EXPECT_EQ(infra_sites(Permutation::k2Infra).size(), 2u);
  for (const auto& s : infra_sites(Permutation::k4Infra)) {
    EXPECT_NEAR(s.sensor_to_enu.translation().z(), 5.0, 1e-12);
    const Eigen::Vector3d fwd = s.sensor_to_enu.linear().col(0);
    EXPECT_LT(fwd.z(), -0.1);  // tilted down
    EXPECT_LT(fwd.head<2>().dot(s.sensor_to_enu.translation().head<2>()), 0.0);  // faces the centre
  }
  Permutation p;
  EXPECT_TRUE(parse_permutation("2_infra", p));
  EXPECT_EQ(p, Permutation::k2Infra);
  EXPECT_FALSE(parse_permutation("3_infra", p));
}

}  // namespace
}  // namespace v2xloc::sim
