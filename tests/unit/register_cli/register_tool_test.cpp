// Runs the v2xloc-register executable on the real outdoor pair and checks its JSON and exit codes.
// Host only: spawns the host-built tool; its JSON is parsed with nlohmann-json.
#include "host_sim/cloud_io/cloud_io.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sys/wait.h>
#include <unistd.h>
#include <utility>
#include <vector>

namespace {

const std::string kTool = std::string(V2XLOC_BINARY_DIR) + "/bin/v2xloc-register";
const std::string kPair = std::string(V2XLOC_SHARED_DATA_DIR) + "/outdoor_lidar_pair";

struct ToolRun {
  int exit_code = -1;
  std::string out;
};

ToolRun run(const std::string& args) {
  ToolRun r;
  std::FILE* pipe = popen((kTool + " " + args).c_str(), "r");
  if (pipe == nullptr) return r;
  char buf[4096];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof(buf), pipe)) > 0) r.out.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

bool read_matrix(std::istream& in, Eigen::Matrix4d& m) {
  for (int i = 0; i < 16; ++i) {
    if (!(in >> m(i / 4, i % 4))) return false;
  }
  return true;
}

// The tool's single output line parsed (ordered, like the tool writes it); discarded on bad JSON.
nlohmann::ordered_json parse(const std::string& out) {
  return nlohmann::ordered_json::parse(out, nullptr, /*allow_exceptions=*/false);
}

bool valid_json(const std::string& json) { return nlohmann::json::accept(json); }

// The final registration's "transform" rows.
bool json_transform(const std::string& json, Eigen::Matrix4d& m) {
  nlohmann::ordered_json j = parse(json);
  if (j.is_discarded() || !j.contains("transform") || j["transform"].size() != 4) return false;
  for (int r = 0; r < 4; ++r) {
    const auto& row = j["transform"][r];
    if (row.size() != 4) return false;
    for (int c = 0; c < 4; ++c) {
      if (!row[c].is_number()) return false;
      m(r, c) = row[c].get<double>();
    }
  }
  return true;
}

void expect_close_to_reference(const std::string& json) {
  Eigen::Matrix4d reference, estimate;
  std::ifstream ref_file(kPair + "/T_target_source.txt");
  ASSERT_TRUE(read_matrix(ref_file, reference));
  ASSERT_TRUE(json_transform(json, estimate)) << json;
  const Eigen::Matrix4d delta = reference.inverse() * estimate;
  const double translation = delta.topRightCorner<3, 1>().norm();
  const double cos_angle = std::clamp((delta.topLeftCorner<3, 3>().trace() - 1.0) / 2.0, -1.0, 1.0);
  const double angle_deg = std::acos(cos_angle) * 180.0 / M_PI;
  EXPECT_LT(translation, 0.05) << json;
  EXPECT_LT(angle_deg, 0.5) << json;
  std::printf("  translation error %.4f m, rotation error %.4f deg\n", translation, angle_deg);
}

class RegisterTool : public testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(kTool)) GTEST_SKIP() << "tool not built: " << kTool;
    if (!std::filesystem::exists(kPair + "/source.ply")) GTEST_SKIP() << "shared data absent: " << kPair;
  }
};

TEST_F(RegisterTool, GlobalModeRecoversTheOutdoorReference) {
  const ToolRun r = run(kPair + "/source.ply " + kPair + "/target.ply --voxel 0.25 --seed 7");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  ASSERT_TRUE(valid_json(r.out)) << r.out;
  nlohmann::ordered_json j = parse(r.out);
  EXPECT_EQ(j.begin().key(), "status") << r.out;
  EXPECT_EQ(j["status"], "ok") << r.out;
  for (const char* key : {"fitness", "inlier_rmse", "iterations"}) {
    EXPECT_TRUE(j[key].is_number()) << key;
  }
  for (const char* key : {"source_downsampled", "correspondences"}) {
    EXPECT_TRUE(j["points"][key].is_number_unsigned()) << key;
  }
  ASSERT_TRUE(j["ms"].is_object()) << r.out;
  for (const char* key : {"ransac", "icp"}) {
    EXPECT_TRUE(j["ms"][key].is_number()) << key;
  }
  expect_close_to_reference(r.out);
  std::printf("  %s", r.out.c_str());
}

// Approximate feature matching (a node-visit budget per 33-D query): cut queries are counted
// separately from search-cap hits, and the outdoor pair is still recovered.
TEST_F(RegisterTool, ApproximateFeatureSearchRecoversTheOutdoorReference) {
  const ToolRun r =
      run(kPair + "/source.ply " + kPair + "/target.ply --voxel 0.25 --seed 7 --feature-visits 24");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  nlohmann::ordered_json j = parse(r.out);
  ASSERT_FALSE(j.is_discarded()) << r.out;
  EXPECT_EQ(j["feature_search_visits"], 24) << r.out;
  EXPECT_EQ(j["dropped"]["search_cap_hits"], 0) << r.out;
  ASSERT_TRUE(j["dropped"]["feature_queries_cut"].is_number_unsigned()) << r.out;
  EXPECT_GT(j["dropped"]["feature_queries_cut"].get<std::uint64_t>(), 0u) << r.out;
  expect_close_to_reference(r.out);
}

TEST_F(RegisterTool, IcpModeFromAPerturbedInitialGuess) {
  Eigen::Matrix4d reference;
  std::ifstream ref_file(kPair + "/T_target_source.txt");
  ASSERT_TRUE(read_matrix(ref_file, reference));
  Eigen::Affine3d offset(Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()));
  offset.translation() = Eigen::Vector3d(0.3, -0.2, 0.05);
  const Eigen::Matrix4d init = offset.matrix() * reference;
  const std::string init_path = testing::TempDir() + "/v2xloc_init.txt";
  {
    std::ofstream f(init_path);
    f.precision(17);
    f << init << "\n";
  }
  const ToolRun r = run(kPair + "/source.ply " + kPair + "/target.ply --mode icp --voxel 0.25 --init " + init_path);
  std::remove(init_path.c_str());
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(parse(r.out)["mode"], "icp") << r.out;
  expect_close_to_reference(r.out);
}

TEST_F(RegisterTool, ExitCodes) {
  EXPECT_EQ(run("").exit_code, 2);
  EXPECT_EQ(run(kPair + "/source.ply 2>/dev/null").exit_code, 2);
  EXPECT_EQ(run(kPair + "/nope.ply " + kPair + "/target.ply 2>/dev/null").exit_code, 2);
  EXPECT_EQ(run(kPair + "/source.ply " + kPair + "/target.ply --mode ndt 2>/dev/null").exit_code, 2);
  EXPECT_EQ(run(kPair + "/source.ply " + kPair + "/T_target_source.txt 2>/dev/null").exit_code, 2);
  // Two points cannot be registered: exit 1 with the JSON still printed.
  v2xloc::cloud_io::PointCloud tiny;
  tiny.points = {Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1, 0, 0)};
  const std::string tiny_path = testing::TempDir() + "/v2xloc_tiny.pcd";
  std::string error;
  ASSERT_TRUE(v2xloc::cloud_io::write_cloud(tiny_path, tiny, error)) << error;
  const ToolRun r = run(tiny_path + " " + tiny_path);
  std::remove(tiny_path.c_str());
  EXPECT_EQ(r.exit_code, 1) << r.out;
  ASSERT_TRUE(valid_json(r.out)) << r.out;
  nlohmann::ordered_json j = parse(r.out);
  EXPECT_EQ(j.begin().key(), "status") << r.out;
  ASSERT_TRUE(j["status"].is_string()) << r.out;
  EXPECT_NE(j["status"], "ok") << r.out;
}

TEST_F(RegisterTool, HostileFilesExitWithAClearError) {
  // Files an attacker controls: the tool must refuse each with exit 2 and the file's name in the
  // message, within seconds (`timeout` turns a hang into exit 124).
  const std::string dir = testing::TempDir() + "/v2xloc_register_hostile_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string pcd_head = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\n";
  const std::string ply_vertex = "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  const std::vector<std::pair<std::string, std::string>> files = {
      {"viewpoint_inf.pcd", pcd_head + "VIEWPOINT inf 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n0 0 0\n1 0 0\n0 1 0\n"},
      {"lying_points.pcd", pcd_head + "POINTS 3000000000\nDATA binary\n" + std::string(36, '\0')},
      {"bad_lzf.pcd", pcd_head + "POINTS 3\nDATA binary_compressed\n" + std::string("\x08\0\0\0\x24\0\0\0\xe0\xff\xff\0\0\0\0\0", 16)},
      {"ply_count_1e10.ply", "ply\nformat ascii 1.0\nelement junk 10000000000\nproperty uchar a\n" + ply_vertex + "1 2 3\n"},
      {"ply_no_end_header.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"},
      {"odd_size.bin", std::string(17, '\0')},
  };
  for (const auto& [name, bytes] : files) {
    const std::string path = dir + "/" + name;
    std::ofstream(path, std::ios::binary) << bytes;
    for (const std::string& args : {path + " " + kPair + "/target.ply", kPair + "/source.ply " + path}) {
      ToolRun r;
      std::FILE* pipe = popen(("timeout 20 " + kTool + " " + args + " 2>&1").c_str(), "r");
      ASSERT_NE(pipe, nullptr);
      char buf[4096];
      std::size_t n = 0;
      while ((n = std::fread(buf, 1, sizeof(buf), pipe)) > 0) r.out.append(buf, n);
      const int status = pclose(pipe);
      r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      EXPECT_EQ(r.exit_code, 2) << name << ": " << r.out;
      EXPECT_NE(r.out.find(name), std::string::npos) << name << ": " << r.out;
    }
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
