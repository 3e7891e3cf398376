#include "host_sim/recording/pose_io.hpp"

#include "host_sim/common/text_file.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <istream>

namespace v2xloc::sim {
namespace {

// Writers store unit quaternions with >= 9 decimals; 1e-3 admits any honest rounding and rejects
// quaternions that would silently rescale into a different rotation.
constexpr double kUnitQuaternionTolerance = 1e-3;
// 100 Hz for 24 h: far above any recording, low enough that a hostile file cannot eat the RAM.
constexpr std::size_t kMaxTumPoses = 10'000'000;

bool make_pose(const double v[7], Eigen::Isometry3d& out) {
  for (int k = 0; k < 7; ++k)
    if (!std::isfinite(v[k])) return false;
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (std::abs(q.norm() - 1.0) > kUnitQuaternionTolerance) return false;
  out = Eigen::Isometry3d::Identity();
  out.linear() = q.normalized().toRotationMatrix();
  out.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return true;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r'; }

// Exactly `n` finite-or-not numbers separated by blanks, nothing else on the line.
bool parse_numbers(const std::string& line, double* values, int n) {
  const char* p = line.data();
  const char* end = p + line.size();
  for (int k = 0; k < n; ++k) {
    while (p < end && is_space(*p)) ++p;
    const auto r = std::from_chars(p, end, values[k]);
    if (r.ec != std::errc() || (r.ptr < end && !is_space(*r.ptr))) return false;
    p = r.ptr;
  }
  while (p < end && is_space(*p)) ++p;
  return p == end;
}

}  // namespace

Json pose_to_json(const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.linear());
  const Eigen::Vector3d t = pose.translation();
  Json j = Json::array();
  for (double v : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) j.push_back(v);
  return j;
}

bool pose_from_json(const Json& j, Eigen::Isometry3d& out) {
  if (!j.is_array() || j.size() != 7) return false;
  double v[7];
  for (int k = 0; k < 7; ++k) {
    if (!j[static_cast<std::size_t>(k)].is_number()) return false;
    v[k] = j[static_cast<std::size_t>(k)].get<double>();
  }
  return make_pose(v, out);
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
  return parse_tum(in, path, out, error);
}

bool parse_tum(std::istream& in, const std::string& path, std::vector<TimedPose>& out, std::string& error) {
  out.clear();
  std::string line;
  std::size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    const std::string where = path + " line " + std::to_string(number);
    double v[8];  // t x y z qx qy qz qw
    TimedPose tp;
    if (!parse_numbers(line, v, 8)) {
      error = where + ": want 8 numbers 't x y z qx qy qz qw'";
      return false;
    }
    if (!std::isfinite(v[0]) || !make_pose(v + 1, tp.pose)) {
      error = where + ": non-finite value or non-unit quaternion";
      return false;
    }
    tp.t = v[0];
    if (!out.empty() && !(tp.t > out.back().t)) {
      error = where + ": time stamps must increase";
      return false;
    }
    if (out.size() >= kMaxTumPoses) {
      error = path + ": more than " + std::to_string(kMaxTumPoses) + " poses";
      return false;
    }
    out.push_back(tp);
  }
  if (in.bad()) {
    error = "read failed: " + path;
    return false;
  }
  return true;
}

}  // namespace v2xloc::sim
