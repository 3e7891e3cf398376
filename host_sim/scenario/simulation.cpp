#include "host_sim/scenario/simulation.hpp"

namespace v2xloc::sim {

void build_simulation(int scenario_id, std::uint64_t seed, double duration, WorldConfig world_config,
                      Simulation& out) {
  out.scenario = make_scenario(scenario_id, duration, world_config.terrain);
  world_config.seed = seed;
  build_intersection_world(world_config, out.iw);
  const Trajectory ego = out.scenario.ego;
  out.ego_body = out.iw.world.add_dynamic_body(make_car_body("ego", [ego](double t) { return ego.pose(t); }));
  out.agent_bodies.clear();
  for (std::size_t i = 0; i < out.scenario.agents.size(); ++i) {
    const Trajectory a = out.scenario.agents[i];
    out.agent_bodies.push_back(out.iw.world.add_dynamic_body(
        make_car_body("agent_" + std::to_string(i), [a](double t) { return a.pose(t); })));
  }
  out.iw.world.set_time(0.0);
}

}  // namespace v2xloc::sim
