// v2xloc-register's argument parsing, 4x4 file reading and JSON layout (no process spawned).
#include "tools/register/register_cli.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

namespace v2xloc::tools {
namespace {

TEST(RegisterCli, ParsesEveryOption) {
  RegisterOptions o;
  std::string error;
  ASSERT_TRUE(parse_register_args({"a.pcd", "--voxel", "0.25", "b.ply", "--mode", "icp", "--init",
                                   "t.txt", "--seed", "42", "--feature-visits", "24"}, o, error))
      << error;
  EXPECT_EQ(o.source_path, "a.pcd");
  EXPECT_EQ(o.target_path, "b.ply");
  EXPECT_EQ(*o.voxel, 0.25f);
  EXPECT_EQ(o.mode, RegistrationMode::kIcpOnly);
  EXPECT_EQ(*o.init_path, "t.txt");
  EXPECT_EQ(*o.seed, 42u);
  EXPECT_EQ(*o.feature_visits, 24u);
}

TEST(RegisterCli, RejectsBadUsageWithAMessage) {
  const std::vector<std::vector<std::string>> bad = {
      {}, {"a.pcd"}, {"a", "b", "c"}, {"a", "b", "--voxel"}, {"a", "b", "--voxel", "-1"},
      {"a", "b", "--voxel", "x"}, {"a", "b", "--mode", "ndt"}, {"a", "b", "--seed", "-3"},
      {"a", "b", "--feature-visits", "x"},
      {"a", "b", "--frobnicate", "1"}};
  for (const auto& args : bad) {
    RegisterOptions o;
    std::string error;
    EXPECT_FALSE(parse_register_args(args, o, error));
    EXPECT_FALSE(error.empty());
  }
}

TEST(RegisterCli, ReadsMatrixFilesAndRejectsNonRigidOnes) {
  const std::string path = testing::TempDir() + "/v2xloc_m4.txt";
  auto write = [&](const char* text) {
    std::ofstream(path) << text;
  };
  Mat4d m;
  std::string error;
  write("# comment\n 0 -1 0 1.5\n1 0 0 -2 # trailing\n0 0 1 0.25\n0 0 0 1\n");
  ASSERT_TRUE(read_matrix4(path, m, error)) << error;
  EXPECT_EQ(m(0, 1), -1.0);
  EXPECT_EQ(m(1, 3), -2.0);
  EXPECT_EQ(m(2, 3), 0.25);
  write("1 0 0 0 0 1 0 0 0 0 1 0 0 0 0");
  EXPECT_FALSE(read_matrix4(path, m, error));
  write("2 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1");
  EXPECT_FALSE(read_matrix4(path, m, error));
  write("1 0 0 0 0 1 0 0 0 0 1 0 1 0 0 1");
  EXPECT_FALSE(read_matrix4(path, m, error));
  write("1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 7");
  EXPECT_FALSE(read_matrix4(path, m, error));
  std::remove(path.c_str());
  EXPECT_FALSE(read_matrix4(path, m, error));
}

TEST(RegisterCli, JsonCarriesTransformBitsAndStages) {
  RegisterOptions o;
  o.source_path = "s\"q.pcd";
  o.target_path = "t.pcd";
  RegisterCloudsParams params;
  RegisterCloudsResult r;
  r.registration.status = RegistrationStatus::kOk;
  r.registration.transform(0, 3) = 0.1;
  r.registration.transform(2, 1) = -1.0 / 3.0;
  r.registration.fitness = 0.75;
  r.stats.source_downsampled = 1234;
  RegisterTimings t;
  t.stage_ms[static_cast<int>(RegisterStage::kIcp)] = 12.5;
  const std::string json = register_json(o, params, r, t);
  EXPECT_EQ(json.rfind("{\"status\":\"ok\",\"transform\":[[1,0,0,0.10000000000000001],[0,1,0,0],"
                       "[0,-0.33333333333333331,1,0],[0,0,0,1]]", 0), 0u) << json;
  EXPECT_NE(json.find("\"fitness\":0.75"), std::string::npos);
  EXPECT_NE(json.find("\"source_downsampled\":1234"), std::string::npos);
  EXPECT_NE(json.find("\"icp\":12.500"), std::string::npos);
  EXPECT_NE(json.find("\"source\":\"s\\\"q.pcd\""), std::string::npos);
  EXPECT_NE(json.find("\"coarse\":{\"status\":\"invalid_input\""), std::string::npos);
  EXPECT_EQ(json.back(), '\n');
  EXPECT_EQ(json.find('\n'), json.size() - 1);
}

}  // namespace
}  // namespace v2xloc::tools
