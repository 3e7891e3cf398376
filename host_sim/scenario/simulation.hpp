// A ready-to-render simulation: the intersection world with the ego and both agent vehicles
// added as moving bodies following the scenario's trajectories. Shared by the recorder, the GNSS
// model and tests.
#pragma once

#include "host_sim/scenario/scenario.hpp"
#include "host_sim/world/intersection_world.hpp"

#include <cstdint>

namespace v2xloc::sim {

struct Simulation {
  Scenario scenario;
  IntersectionWorld iw;
  int ego_body = -1;                 // World dynamic body indices (exclude a carrier's own body)
  std::vector<int> agent_bodies;
};

// The world layout depends on the seed; `world_config.seed` is overwritten with `seed`. The
// vehicles drive on `world_config.terrain`.
void build_simulation(int scenario_id, std::uint64_t seed, double duration, WorldConfig world_config,
                      Simulation& out);

}  // namespace v2xloc::sim
