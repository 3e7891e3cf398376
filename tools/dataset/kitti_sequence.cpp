#include "tools/dataset/kitti_sequence.hpp"

#include "tools/dataset/dataset_common.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace v2xloc::dataset {
namespace {

// Reads exactly `n` finite numbers from `line`; false if fewer, more or not numbers.
bool parse_numbers(const std::string& line, std::size_t n, std::vector<double>& out) {
  std::istringstream in(line);
  out.clear();
  double v = 0.0;
  while (in >> v) {
    if (!std::isfinite(v)) return false;
    out.push_back(v);
  }
  return in.eof() && out.size() == n;
}

Mat4d from_3x4(const std::vector<double>& v) {
  Mat4d m = Mat4d::Identity();
  for (int i = 0; i < 12; ++i) m(i / 4, i % 4) = v[static_cast<std::size_t>(i)];
  return m;
}

bool is_rotation(const Mat4d& m) {
  const Mat3d r = m.topLeftCorner<3, 3>();
  return (r.transpose() * r - Mat3d::Identity()).cwiseAbs().maxCoeff() < 1e-3 && r.determinant() > 0.0;
}

bool blank(const std::string& line) { return line.find_first_not_of(" \t\r") == std::string::npos; }

}  // namespace

bool read_kitti_calib_tr(const std::string& path, Mat4d& tr, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot open '" + path + "' (KITTI calib.txt with a 'Tr:' line)";
    return false;
  }
  std::string line;
  std::vector<double> v;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.rfind("Tr:", 0) != 0) continue;
    if (!parse_numbers(line.substr(3), 12, v)) {
      error = path + ":" + std::to_string(n) + ": 'Tr:' needs 12 numbers (3x4 row-major)";
      return false;
    }
    tr = from_3x4(v);
    if (!is_rotation(tr)) {
      error = path + ":" + std::to_string(n) + ": the rotation part of Tr is not a rotation";
      return false;
    }
    return true;
  }
  error = "'" + path + "' has no 'Tr:' line (velodyne -> camera 0 transform)";
  return false;
}

bool read_kitti_times(const std::string& path, std::vector<double>& times, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot open '" + path + "' (one timestamp per scan)";
    return false;
  }
  times.clear();
  std::string line;
  std::vector<double> v;
  for (int n = 1; std::getline(in, line); ++n) {
    if (blank(line)) continue;
    if (!parse_numbers(line, 1, v)) {
      error = path + ":" + std::to_string(n) + ": expected one number, got '" + line + "'";
      return false;
    }
    if (!times.empty() && v[0] < times.back()) {
      error = path + ":" + std::to_string(n) + ": timestamps go backwards";
      return false;
    }
    times.push_back(v[0]);
  }
  return true;
}

bool read_kitti_poses(const std::string& path, std::vector<Mat4d>& poses, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot open '" + path + "'";
    return false;
  }
  poses.clear();
  std::string line;
  std::vector<double> v;
  for (int n = 1; std::getline(in, line); ++n) {
    if (blank(line)) continue;
    if (!parse_numbers(line, 12, v)) {
      error = path + ":" + std::to_string(n) + ": expected 12 numbers (3x4 row-major pose)";
      return false;
    }
    poses.push_back(from_3x4(v));
    if (!is_rotation(poses.back())) {
      error = path + ":" + std::to_string(n) + ": the rotation part is not a rotation";
      return false;
    }
  }
  return true;
}

bool write_kitti_poses(const std::string& path, const std::vector<Mat4d>& poses, std::string& error) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    error = "cannot write '" + path + "'";
    return false;
  }
  for (const Mat4d& p : poses) {
    for (int i = 0; i < 12; ++i) std::fprintf(f, i ? " %.9e" : "%.9e", p(i / 4, i % 4));
    std::fputc('\n', f);
  }
  if (std::fclose(f) != 0) {
    error = "error writing '" + path + "'";
    return false;
  }
  return true;
}

Mat4d velo_pose_to_cam(const Mat4d& velo_pose, const Mat4d& tr) {
  Mat4d tr_inv = Mat4d::Identity();
  tr_inv.topLeftCorner<3, 3>() = tr.topLeftCorner<3, 3>().transpose();
  tr_inv.topRightCorner<3, 1>() = -tr.topLeftCorner<3, 3>().transpose() * tr.topRightCorner<3, 1>();
  return tr * velo_pose * tr_inv;
}

bool load_kitti_sequence(const std::string& dir, const std::optional<std::string>& poses_override,
                         KittiSequence& out, std::string& error) {
  namespace fs = std::filesystem;
  out = KittiSequence{};
  if (!is_directory(dir)) {
    error = "'" + dir + "' is not a directory (expected a KITTI sequence folder)";
    return false;
  }
  out.dir = dir;
  out.name = fs::path(dir).lexically_normal().filename().string();
  if (out.name.empty()) out.name = fs::path(dir).lexically_normal().parent_path().filename().string();
  const std::string velodyne = dir + "/velodyne";
  if (!is_directory(velodyne)) {
    error = "'" + dir + "' has no velodyne/ folder (KITTI sequence: velodyne/NNNNNN.bin, times.txt, calib.txt)";
    return false;
  }
  if (!list_files(velodyne, ".bin", out.scans, error)) return false;
  if (out.scans.empty()) {
    error = "'" + velodyne + "' holds no .bin scans";
    return false;
  }
  if (!read_kitti_times(dir + "/times.txt", out.times, error)) return false;
  if (out.times.size() != out.scans.size()) {
    error = dir + "/times.txt has " + std::to_string(out.times.size()) + " timestamps for " +
            std::to_string(out.scans.size()) + " scans";
    return false;
  }
  if (!read_kitti_calib_tr(dir + "/calib.txt", out.velo_to_cam, error)) return false;

  if (poses_override) {
    out.poses_path = *poses_override;
  } else if (is_file(dir + "/poses.txt")) {
    out.poses_path = dir + "/poses.txt";
  } else {
    const fs::path official = fs::path(dir).lexically_normal().parent_path().parent_path() / "poses" /
                              (out.name + ".txt");
    if (!out.name.empty() && is_file(official.string())) out.poses_path = official.string();
  }
  if (!out.poses_path.empty()) {
    if (!read_kitti_poses(out.poses_path, out.poses, error)) return false;
    if (out.poses.size() != out.scans.size()) {
      error = out.poses_path + " has " + std::to_string(out.poses.size()) + " poses for " +
              std::to_string(out.scans.size()) + " scans";
      return false;
    }
  }
  return true;
}

}  // namespace v2xloc::dataset
