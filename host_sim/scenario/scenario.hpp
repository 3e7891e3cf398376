// The four scenarios of the paper's Fig. 2 and the three sensor permutations.
//   Sim 0: ego crosses straight (eastbound); agent 0 drives the parallel opposing path (westbound);
//          agent 1 waits at the northbound stop line.
//   Sim 1: agents stationary (both waiting at the N-S stop lines); ego crosses westbound.
//   Sim 2: ego crosses eastbound; agent 0 crosses on the perpendicular path (northbound);
//          agent 1 waits at the westbound stop line.
//   Sim 3: ego (northbound) and agent 0 (southbound) both turn left; agent 1 waits eastbound.
// Right-hand traffic, vehicles in the inner lanes (1.75 m from the road axis).
#pragma once

#include "host_sim/scenario/trajectory.hpp"

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace v2xloc::sim {

enum class Permutation { k4Infra2Agent, k4Infra, k2Infra };
const char* permutation_name(Permutation p);
bool parse_permutation(const std::string& name, Permutation& out);
constexpr Permutation kAllPermutations[] = {Permutation::k4Infra2Agent, Permutation::k4Infra, Permutation::k2Infra};

struct Scenario {
  int id = 0;
  std::string name;          // "sim0"
  std::string description;
  double duration = 24.0;    // s
  double frame_rate = 10.0;  // Hz (ego LiDAR sweeps, stereo frames, ground truth)
  // Each drive is recorded at its own time of day: the GNSS constellation snapshot (and so the
  // canyon's blocking pattern) differs between scenarios, as between real drives.
  double gnss_epoch_offset_s = 0.0;
  Trajectory ego;
  std::vector<Trajectory> agents;  // always two (they exist in the world in every permutation)
  int frame_count() const { return static_cast<int>(duration * frame_rate + 0.5); }
};

constexpr int kScenarioCount = 4;
// duration <= 0: the scenario's default (24-30 s). The vehicles drive on `terrain`.
Scenario make_scenario(int id, double duration = 0.0, const Terrain& terrain = {});

struct InfraSite {
  std::string name;            // infra_0 .. infra_3 (NE, NW, SW, SE corners)
  Eigen::Isometry3d sensor_to_enu;  // surveyed pose
};
// Four corner units, or the two diagonal ones (NE, SW) for 2_infra. All 5 m above the ground
// under them, facing the centre, tilted 10 deg down.
std::vector<InfraSite> infra_sites(Permutation p, const Terrain& terrain = {});
inline bool uses_agents(Permutation p) { return p == Permutation::k4Infra2Agent; }

}  // namespace v2xloc::sim
