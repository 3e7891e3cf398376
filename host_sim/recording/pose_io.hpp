// Poses as [x y z qx qy qz qw] arrays (manifest) and TUM trajectory lines (t x y z qx qy qz qw).
// Readers are strict: every number finite, quaternions unit length (within the rounding of the
// writers), TUM stamps strictly increasing; anything else is an error with the line it came from.
#pragma once

#include <Eigen/Geometry>
#include <iosfwd>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace v2xloc::sim {

// Insertion-ordered, so written manifests are byte-stable and read in the order written.
using Json = nlohmann::ordered_json;

struct TimedPose {
  double t = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};

Json pose_to_json(const Eigen::Isometry3d& pose);
// False (out untouched) unless j is an array of exactly 7 finite numbers with a unit quaternion.
bool pose_from_json(const Json& j, Eigen::Isometry3d& out);
std::string tum_line(double t, const Eigen::Isometry3d& pose);
bool write_tum(const std::string& path, const std::vector<TimedPose>& poses, std::string& error);
bool read_tum(const std::string& path, std::vector<TimedPose>& out, std::string& error);
// The same on a stream; `name` prefixes the errors.
bool parse_tum(std::istream& in, const std::string& name, std::vector<TimedPose>& out, std::string& error);

}  // namespace v2xloc::sim
