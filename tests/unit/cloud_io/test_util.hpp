// Helpers for the cloud_io tests: fixture paths and the expected-values side files.
#pragma once

#include "host_sim/cloud_io/cloud_io.hpp"

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace v2xloc::cloud_io::test {

inline std::string fixture(const std::string& name) {
  return std::string(V2XLOC_SOURCE_DIR) + "/tests/data/pcd_fixtures/" + name;
}

// Rows of `<stem>.expected.txt` (written by tools/fixtures/make_pcd_fixtures.py); the first line
// names the columns.
struct Expected {
  std::vector<std::string> columns;
  std::vector<std::vector<float>> rows;
};

inline bool read_expected(const std::string& path, Expected& e) {
  std::ifstream in(path);
  if (!in) return false;
  std::string line;
  std::getline(in, line);
  std::istringstream header(line);
  std::string word;
  header >> word;  // '#'
  while (header >> word) e.columns.push_back(word);
  while (std::getline(in, line)) {
    std::istringstream row(line);
    std::vector<float> values;
    double v = 0.0;
    while (row >> v) values.push_back(static_cast<float>(v));
    if (!values.empty()) e.rows.push_back(values);
  }
  return true;
}

// Small deterministic cloud with every attribute.
inline PointCloud make_cloud(std::size_t n, bool intensity, bool time, bool normals) {
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const float f = static_cast<float>(i);
    c.points.emplace_back(0.1f * f - 3.0f, 1.0f / (f + 1.0f), -2.5e-3f * f * f);
    if (intensity) c.intensity.push_back(f * 0.7f);
    if (time) c.time.push_back(1e-4f * f);
    if (normals) c.normals.push_back(Eigen::Vector3f(1.0f, f, -0.5f).normalized());
  }
  c.width = static_cast<std::uint32_t>(n);
  return c;
}

}  // namespace v2xloc::cloud_io::test
