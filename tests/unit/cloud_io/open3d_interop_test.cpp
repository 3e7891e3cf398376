// Our PCD writer's files load in Open3D (python3-open3d) with the same values (issue 3, item 5).
// Host only: spawns /usr/bin/python3.
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <sstream>
#include <vector>

namespace v2xloc::cloud_io {
namespace {

const char* kPython = "/usr/bin/python3";

bool run(const std::string& command, std::string& output) {
  output.clear();
  std::FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return false;
  char buf[4096];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof(buf), pipe)) > 0) output.append(buf, n);
  return pclose(pipe) == 0;
}

// Writes the cloud in every PCD encoding, dumps all files with Open3D in one python call
// (importing open3d takes seconds) and compares every value bit for bit.
TEST(Open3dInterop, OurPcdFilesLoadInOpen3dWithTheSameValues) {
  if (!std::filesystem::exists(kPython)) GTEST_SKIP() << kPython << " not found";
  const PointCloud cloud = test::make_cloud(200, true, false, true);
  const std::string script = std::string(V2XLOC_SOURCE_DIR) + "/tools/fixtures/o3d_dump_cloud.py";
  std::string command = std::string(kPython) + " " + script;
  std::vector<std::string> paths;
  for (PcdEncoding enc : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    paths.push_back(testing::TempDir() + "/v2xloc_o3d_" + std::to_string(static_cast<int>(enc)) + ".pcd");
    std::string error;
    ASSERT_TRUE(write_pcd(paths.back(), cloud, enc, error)) << error;
    command += " " + paths.back();
  }
  std::string out;
  const bool ok = run(command + " 2>&1", out);
  for (const std::string& p : paths) std::remove(p.c_str());
  if (!ok && out.find("No module named 'open3d'") != std::string::npos) {
    GTEST_SKIP() << "python3-open3d not installed";
  }
  ASSERT_TRUE(ok) << out;
  std::istringstream in(out);
  for (std::size_t file = 0; file < paths.size(); ++file) {
    SCOPED_TRACE(paths[file]);
    std::string word;
    std::size_t n = 0;
    in >> word >> n;
    ASSERT_EQ(word, "points");
    ASSERT_EQ(n, cloud.size());
    std::string attributes;
    std::getline(in, attributes);
    std::getline(in, attributes);
    EXPECT_EQ(attributes, "attributes intensity normals positions");
    for (std::size_t i = 0; i < n; ++i) {
      double v[7];
      for (double& x : v) ASSERT_TRUE(in >> x) << "row " << i;
      ASSERT_EQ(Eigen::Vector3f(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])),
                cloud.points[i]) << "row " << i;
      ASSERT_EQ(Eigen::Vector3f(static_cast<float>(v[3]), static_cast<float>(v[4]), static_cast<float>(v[5])),
                cloud.normals[i]) << "row " << i;
      ASSERT_EQ(static_cast<float>(v[6]), cloud.intensity[i]) << "row " << i;
    }
    std::getline(in, word);
  }
}

}  // namespace
}  // namespace v2xloc::cloud_io
