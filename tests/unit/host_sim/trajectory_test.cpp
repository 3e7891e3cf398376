#include "host_sim/scenario/scenario.hpp"
#include "host_sim/scenario/simulation.hpp"
#include "host_sim/world/intersection_world.hpp"

#include <gtest/gtest.h>

#include <algorithm>
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

// A turn eases in and out: the yaw rate never steps (a straight meeting an arc would step it to
// v / R within one sample), the clothoids' quadrature matches a fine Riemann sum, and the turn
// ends on the heading and the lane it aims at.
TEST(HostSimScenario, TurnsEaseInAndOutOnClothoids) {
  const double radius = 10.0, transition = 6.0;
  Path turn({0.0, 0.0, 0.0});
  turn.straight(5.0).turn(radius, M_PI / 2, transition).straight(20.0);
  EXPECT_NEAR(turn.length(), 5.0 + radius * M_PI / 2 + transition + 20.0, 1e-12);
  const PlanarPose end = turn.at(turn.length());
  EXPECT_NEAR(end.yaw, M_PI / 2, 1e-12);
  EXPECT_NEAR(end.y - 20.0, turn.at(5.0 + radius * M_PI / 2 + transition).y, 1e-9);
  // Symmetric quarter turn: it reaches as far sideways as forward, beyond the plain arc's radius.
  const PlanarPose out = turn.at(5.0 + radius * M_PI / 2 + transition);
  EXPECT_NEAR(out.x - 5.0, out.y, 1e-9);
  EXPECT_GT(out.y, radius + 0.5 * transition - 0.1);
  // Curvature continuous and the position the integral of the heading (Riemann sum, 1 mm steps).
  double x = 0.0, y = 0.0, last_k = 0.0;
  const int steps = static_cast<int>(std::lround(turn.length() / 1e-3));
  const double step = turn.length() / steps;
  for (int i = 0; i < steps; ++i) {
    const double s = i * step;
    const double k = turn.curvature(s + step / 2);
    EXPECT_LT(std::abs(k - last_k), 2.0 * step / (radius * transition)) << s;
    last_k = k;
    const double yaw = turn.at(s + step / 2).yaw;
    x += step * std::cos(yaw);
    y += step * std::sin(yaw);
  }
  EXPECT_NEAR(x, end.x, 1e-6);
  EXPECT_NEAR(y, end.y, 1e-6);
  // Sim 3's ego: yaw acceleration bounded by the clothoid's (v^2 / (R L) plus the speed's change).
  const Scenario s3 = make_scenario(3);
  double max_rate = 0.0;
  for (double t = 0.0; t < s3.duration; t += 0.01) {
    const double a = (s3.ego.state(t + 0.01).yaw_rate - s3.ego.state(t).yaw_rate) / 0.01;
    EXPECT_LT(std::abs(a), 1.0) << t;
    max_rate = std::max(max_rate, std::abs(s3.ego.state(t).yaw_rate));
  }
  EXPECT_GT(max_rate, 0.5);  // the turn is in there
  EXPECT_NEAR(s3.ego.pose(s3.duration).y, IntersectionLayout::kInnerLane, 1e-9);  // the westbound lane
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
