// Top-view PNG of a scenario in the style of the paper's Fig. 2: buildings, sidewalks, trees,
// poles, infrastructure LiDARs, ego and agent paths, GNSS fixes (the truth is the ego path), with
// a title, a legend, a 20 m scale bar and a north arrow.
#pragma once

#include "host_sim/world/intersection_world.hpp"

#include <Eigen/Core>
#include <string>
#include <vector>

namespace v2xloc::sim {

struct TopViewData {
  std::string title;
  std::vector<Eigen::Vector2d> ego_path;
  std::vector<std::vector<Eigen::Vector2d>> agent_paths;
  std::vector<Eigen::Vector2d> infra;
  std::vector<Eigen::Vector2d> gnss_fixes;
  bool agents_have_lidar = true;
};

bool write_top_view(const std::string& path, const IntersectionWorld& iw, const TopViewData& data, std::string& error);

}  // namespace v2xloc::sim
