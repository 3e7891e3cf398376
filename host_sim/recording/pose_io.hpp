// Poses as [x y z qx qy qz qw] arrays (manifest) and TUM trajectory lines (t x y z qx qy qz qw).
#pragma once

#include "host_sim/common/json.hpp"

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace v2xloc::sim {

struct TimedPose {
  double t = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};

Json pose_to_json(const Eigen::Isometry3d& pose);
bool pose_from_json(const Json& j, Eigen::Isometry3d& out);
std::string tum_line(double t, const Eigen::Isometry3d& pose);
bool write_tum(const std::string& path, const std::vector<TimedPose>& poses, std::string& error);
bool read_tum(const std::string& path, std::vector<TimedPose>& out, std::string& error);

}  // namespace v2xloc::sim
