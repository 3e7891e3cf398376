// The four-way intersection of the paper's Fig. 2: two roads (2 lanes each way, 3.5 m lanes)
// crossing at the ENU origin, curbs and sidewalks, buildings with facade detail on all four
// corners (an urban canyon), street lamps, traffic lights, trees and parked cars. Deterministic
// from the seed.
#pragma once

#include "host_sim/world/world.hpp"

#include <cstdint>
#include <vector>

namespace v2xloc::sim {

struct IntersectionLayout {
  static constexpr double kLaneWidth = 3.5;           // m
  static constexpr double kRoadHalfWidth = 7.0;       // 2 lanes each way
  static constexpr double kSidewalkWidth = 4.0;       // m, beyond the curb
  static constexpr double kCurbHeight = 0.15;         // m
  static constexpr double kExtent = 130.0;            // roads and buildings reach |x|,|y| <= extent
  // Lane centre offsets from the road axis (right-hand traffic): inner 1.75 m, outer 5.25 m.
  static constexpr double kInnerLane = 1.75;
  static constexpr double kOuterLane = 5.25;
  static constexpr double kStopLine = 9.0;            // m from the centre, before the crossing
};

struct WorldConfig {
  std::uint64_t seed = 1;
  bool buildings = true;       // false: open sky (GNSS baseline without the canyon)
  bool facade_detail = true;   // ledges, pilasters, balconies
  bool street_furniture = true;
  bool parked_cars = true;
  Terrain terrain;             // the ground the site stands on (flat: z = 0)
};

struct BuildingInfo {  // the layout's blocks, for checks of the canyon
  Eigen::Vector2d lo, hi;  // footprint (axis aligned)
  double height = 0.0;
};

struct IntersectionWorld {
  World world;
  std::vector<BuildingInfo> buildings;
};

// Builds the static world (vehicles are added by the scenario as dynamic bodies).
void build_intersection_world(const WorldConfig& config, IntersectionWorld& out);

}  // namespace v2xloc::sim
