#include "host_sim/scenario/scenario.hpp"

#include "host_sim/world/intersection_world.hpp"

#include <cmath>

namespace v2xloc::sim {
namespace {

using L = IntersectionLayout;
constexpr double kHalfPi = M_PI / 2.0;
constexpr double kWaitOffset = L::kStopLine + 3.0;  // car centre waiting at the stop line

// A 90 deg turn's reach: how far it carries the car sideways (and forward) from where it starts
// turning; the radius for a plain arc, more with its clothoids.
double quarter_turn_reach(double radius, double transition) {
  Path probe({0.0, 0.0, 0.0});
  probe.turn(radius, kHalfPi, transition);
  return probe.at(probe.length()).y;
}

}  // namespace

const char* permutation_name(Permutation p) {
  switch (p) {
    case Permutation::k4Infra2Agent: return "4_infra_2_agent";
    case Permutation::k4Infra: return "4_infra";
    case Permutation::k2Infra: return "2_infra";
  }
  return "?";
}

bool parse_permutation(const std::string& name, Permutation& out) {
  for (Permutation p : kAllPermutations) {
    if (name == permutation_name(p)) {
      out = p;
      return true;
    }
  }
  return false;
}

Scenario make_scenario(int id, double duration, const Terrain& terrain) {
  Scenario sc;
  sc.id = id;
  sc.name = "sim" + std::to_string(id);
  const double lane = L::kInnerLane;
  const double turn_radius = 10.0;
  // [m] each clothoid of a turn: at 6-6.5 m/s the yaw rate ramps up over ~1 s (0.7 rad/s^2), a
  // brisk urban left turn.
  const double turn_transition = 6.0;
  const double turn_reach = quarter_turn_reach(turn_radius, turn_transition);
  const double w = 2.0 * M_PI / 12.0;  // speed oscillation period 12 s
  // Straight runs start kApproach before the centre: the recording covers the V2X zone of the
  // intersection (the infrastructure LiDARs' useful range), where cooperative localization is
  // defined; 20 s at ~6 m/s ends about 80 m beyond it.
  constexpr double kApproach = 40.0;
  switch (id) {
    case 0: {
      sc.description = "ego crosses straight eastbound; agent 0 drives the parallel opposing path";
      sc.duration = 20.0;
      sc.ego = Trajectory(std::move(Path({-kApproach, -lane, 0.0}).straight(250.0)), 0.0, 6.0, 0.5, w);
      sc.agents.push_back(Trajectory(std::move(Path({kApproach, lane, M_PI}).straight(250.0)), 0.0, 6.0, 0.4, w * 1.3));
      sc.agents.push_back(Trajectory::stationary({lane, -kWaitOffset, kHalfPi}));
      break;
    }
    case 1: {
      sc.description = "ego crosses straight westbound; both agents stationary at the stop lines";
      sc.duration = 20.0;
      sc.ego = Trajectory(std::move(Path({kApproach, lane, M_PI}).straight(250.0)), 0.0, 6.0, 0.5, w);
      sc.agents.push_back(Trajectory::stationary({lane, -kWaitOffset, kHalfPi}));
      sc.agents.push_back(Trajectory::stationary({-lane, kWaitOffset, -kHalfPi}));
      break;
    }
    case 2: {
      sc.description = "ego crosses eastbound; agent 0 crosses on the perpendicular path (northbound)";
      sc.duration = 20.0;
      sc.ego = Trajectory(std::move(Path({-kApproach, -lane, 0.0}).straight(250.0)), 0.0, 6.0, 0.5, w);
      sc.agents.push_back(Trajectory(std::move(Path({lane, -30.0, kHalfPi}).straight(250.0)), 0.0, 6.0, 0.5, w * 0.8));
      sc.agents.push_back(Trajectory::stationary({kWaitOffset, lane, M_PI}));
      break;
    }
    case 3: {
      sc.description = "ego (northbound) and agent 0 (southbound) turn left";
      sc.duration = 22.0;
      const double approach = 50.0;
      sc.ego = Trajectory(std::move(Path({lane, -approach, kHalfPi})
                                        .straight(approach - (turn_reach - lane))
                                        .turn(turn_radius, kHalfPi, turn_transition)
                                        .straight(150.0)),
                          0.0, 6.5, 0.5, w);
      const double agent_approach = 45.0;
      sc.agents.push_back(Trajectory(std::move(Path({-lane, agent_approach, -kHalfPi})
                                                   .straight(agent_approach - (turn_reach - lane))
                                                   .turn(turn_radius, kHalfPi, turn_transition)
                                                   .straight(150.0)),
                                     0.0, 6.0, 0.4, w * 1.2));
      sc.agents.push_back(Trajectory::stationary({-kWaitOffset, -lane, 0.0}));
      break;
    }
    default:
      sc.description = "invalid";
      break;
  }
  // Recording times (hours after the constellation epoch). Over 24 hourly epochs the canyon gives a
  // mean horizontal error of 8.8-10.3 m per scenario with 70-85 % of epochs in the paper's 8-17 m
  // band; these times are in-band ones, like the paper's CARLA runs (closing note of issue 3).
  constexpr double kRecordingHour[kScenarioCount] = {0.0, 2.0, 6.0, 9.0};
  if (id >= 0 && id < kScenarioCount) sc.gnss_epoch_offset_s = 3600.0 * kRecordingHour[id];
  if (duration > 0.0) sc.duration = duration;
  sc.ego.set_terrain(terrain);
  for (Trajectory& agent : sc.agents) agent.set_terrain(terrain);
  return sc;
}

std::vector<InfraSite> infra_sites(Permutation p, const Terrain& terrain) {
  const double c = L::kRoadHalfWidth + 2.5;  // on the sidewalk corner
  const double height = 5.0;
  const double tilt = 10.0 * M_PI / 180.0;
  struct Corner { const char* name; double sx, sy; };
  const Corner corners[4] = {{"infra_0", 1, 1}, {"infra_1", -1, 1}, {"infra_2", -1, -1}, {"infra_3", 1, -1}};
  std::vector<InfraSite> out;
  for (int i = 0; i < 4; ++i) {
    if (p == Permutation::k2Infra && (i == 1 || i == 3)) continue;  // keep the NE/SW diagonal
    const Corner& k = corners[i];
    InfraSite s;
    s.name = k.name;
    s.sensor_to_enu = Eigen::Isometry3d::Identity();
    const double yaw = std::atan2(-k.sy, -k.sx);  // face the intersection centre
    // Positive rotation about the sensor's y axis pitches its x axis down.
    s.sensor_to_enu.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitY())).toRotationMatrix();
    s.sensor_to_enu.translation() = Eigen::Vector3d(k.sx * c, k.sy * c, height + terrain.height(k.sx * c, k.sy * c));
    out.push_back(s);
  }
  return out;
}

}  // namespace v2xloc::sim
