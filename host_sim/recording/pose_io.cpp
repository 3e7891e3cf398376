#include "host_sim/recording/pose_io.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>

namespace v2xloc::sim {

Json pose_to_json(const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.linear());
  const Eigen::Vector3d t = pose.translation();
  Json j = Json::array();
  for (double v : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) j.push(Json(v));
  return j;
}

bool pose_from_json(const Json& j, Eigen::Isometry3d& out) {
  if (!j.is_array() || j.size() != 7) return false;
  const auto v = j.as_numbers();
  Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (q.norm() < 1e-9) return false;
  out = Eigen::Isometry3d::Identity();
  out.linear() = q.normalized().toRotationMatrix();
  out.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return true;
}

std::string tum_line(double t, const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.linear());
  const Eigen::Vector3d p = pose.translation();
  char buf[256];
  std::snprintf(buf, sizeof buf, "%.6f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", t, p.x(), p.y(), p.z(), q.x(), q.y(),
                q.z(), q.w());
  return buf;
}

bool write_tum(const std::string& path, const std::vector<TimedPose>& poses, std::string& error) {
  std::string text = "# t x y z qx qy qz qw\n";
  for (const auto& p : poses) text += tum_line(p.t, p.pose);
  return write_text_file(path, text, error);
}

bool read_tum(const std::string& path, std::vector<TimedPose>& out, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot open " + path;
    return false;
  }
  out.clear();
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    double t, x, y, z, qx, qy, qz, qw;
    if (!(ss >> t >> x >> y >> z >> qx >> qy >> qz >> qw)) {
      error = "bad TUM line in " + path + ": " + line;
      return false;
    }
    TimedPose tp;
    tp.t = t;
    tp.pose.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
    tp.pose.translation() = Eigen::Vector3d(x, y, z);
    out.push_back(tp);
  }
  return true;
}

}  // namespace v2xloc::sim
