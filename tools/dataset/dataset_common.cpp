#include "tools/dataset/dataset_common.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <numeric>
#include <system_error>

namespace v2xloc::dataset {

namespace fs = std::filesystem;

double translation_error_m(const Mat4d& estimate, const Mat4d& reference) {
  return (estimate.topRightCorner<3, 1>() - reference.topRightCorner<3, 1>()).norm();
}

double rotation_angle_rad(const Mat3d& r) {
  const double c = std::clamp((r.trace() - 1.0) * 0.5, -1.0, 1.0);
  return std::acos(c);
}

double rotation_error_deg(const Mat4d& estimate, const Mat4d& reference) {
  const Mat3d delta = reference.topLeftCorner<3, 3>().transpose() * estimate.topLeftCorner<3, 3>();
  return rotation_angle_rad(delta) * 180.0 / M_PI;
}

std::uint64_t thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

bool list_files(const std::string& dir, const std::string& extension, std::vector<std::string>& out,
                std::string& error) {
  out.clear();
  std::error_code ec;
  fs::directory_iterator it(dir, ec);
  if (ec) {
    error = "cannot list '" + dir + "': " + ec.message();
    return false;
  }
  for (const fs::directory_entry& e : it) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file(ec) && name.size() > extension.size() &&
        name.compare(name.size() - extension.size(), extension.size(), extension) == 0) {
      out.push_back(e.path().string());
    }
  }
  std::sort(out.begin(), out.end());
  return true;
}

bool is_directory(const std::string& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

bool is_file(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

Stats stats_of(std::vector<double> values) {
  Stats s;
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  s.mean = std::accumulate(values.begin(), values.end(), 0.0) / static_cast<double>(values.size());
  const std::size_t n = values.size();
  s.median = n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
  s.max = values.back();
  return s;
}

}  // namespace v2xloc::dataset
