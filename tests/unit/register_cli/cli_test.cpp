// v2xloc-register's argument parsing, 4x4 file reading and JSON layout (no process spawned); the
// JSON is parsed back with nlohmann-json and compared by value, key order included.
#include "tools/register/register_cli.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

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

// The printed object parsed back (ordered: key order is part of the layout).
nlohmann::ordered_json parse_line(const std::string& text) {
  EXPECT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n');
  EXPECT_EQ(text.find('\n'), text.size() - 1) << "one line";
  return nlohmann::ordered_json::parse(text);
}

std::vector<std::string> keys(const nlohmann::ordered_json& object) {
  std::vector<std::string> names;
  for (const auto& item : object.items()) names.push_back(item.key());
  return names;
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
  t.registration_ms = 1.23456;
  r.registration.inliers = 5000;
  r.registration.converged = true;
  const RegistrationVerdict verdict = judge_registration(r.registration, nullptr);
  ASSERT_EQ(verdict.verdict, Verdict::kOk);
  nlohmann::ordered_json j = parse_line(register_json(o, params, r, t, verdict, {}));

  const std::vector<std::string> top = {"status", "transform", "fitness", "inlier_rmse", "iterations",
                                        "inliers", "converged", "registration_status", "verdict", "mode", "voxel", "seed",
                                        "feature_search_visits", "source", "target", "coarse", "points",
                                        "dropped", "ransac_validations", "icp_iterations", "ms"};
  EXPECT_EQ(keys(j), top);
  EXPECT_EQ(j["status"], "ok");
  // Every transform entry reads back to the same bits.
  Mat4d expected = Mat4d::Identity();
  expected(0, 3) = 0.1;
  expected(2, 1) = -1.0 / 3.0;
  ASSERT_EQ(j["transform"].size(), 4u);
  for (int row = 0; row < 4; ++row) {
    ASSERT_EQ(j["transform"][row].size(), 4u);
    for (int col = 0; col < 4; ++col) {
      EXPECT_EQ(j["transform"][row][col].get<double>(), expected(row, col)) << row << "," << col;
    }
  }
  EXPECT_EQ(j["fitness"].get<double>(), 0.75);
  EXPECT_EQ(j["mode"], "global");
  EXPECT_EQ(j["voxel"].get<double>(), static_cast<double>(params.voxel_size));
  EXPECT_EQ(j["seed"].get<std::uint64_t>(), params.ransac.seed);
  EXPECT_EQ(j["points"]["source_downsampled"], 1234);
  EXPECT_EQ(keys(j["points"]),
            (std::vector<std::string>{"source_input", "target_input", "source_downsampled",
                                      "target_downsampled", "correspondences",
                                      "ransac_correspondence_inliers", "final_inliers", "voxel_used_m",
                                      "voxel_coarsenings"}));
  EXPECT_EQ(keys(j["dropped"]),
            (std::vector<std::string>{"nonfinite", "source_thinned", "target_thinned",
                                      "downsample_overflow", "correspondences_truncated",
                                      "search_cap_hits", "feature_queries_cut"}));
  EXPECT_EQ(keys(j["ms"]), (std::vector<std::string>{"read_source", "read_target", "downsample", "normals",
                                                     "fpfh", "correspondences", "ransac", "icp",
                                                     "search", "registration"}));
  EXPECT_EQ(j["ms"]["icp"].get<double>(), 12.5);
  EXPECT_EQ(j["ms"]["registration"].get<double>(), 1.235);  // to the microsecond
  EXPECT_EQ(j["source"], "s\"q.pcd");
  EXPECT_EQ(j["target"], "t.pcd");
  EXPECT_EQ(j["verdict"]["verdict"], "ok");
  EXPECT_EQ(keys(j["coarse"]), (std::vector<std::string>(top.begin(), top.begin() + 7)));
  EXPECT_EQ(j["coarse"]["status"], "invalid_input");
}

TEST(RegisterCli, JsonWritesNonFiniteNumbersAsNull) {
  RegisterCloudsResult r;
  r.registration.fitness = std::numeric_limits<double>::quiet_NaN();
  r.registration.transform(1, 2) = std::numeric_limits<double>::infinity();
  nlohmann::ordered_json j = parse_line(register_json({}, {}, r, {}, {}, {}));
  EXPECT_TRUE(j["fitness"].is_null());
  EXPECT_TRUE(j["transform"][1][2].is_null());
  EXPECT_EQ(j["transform"][1][1].get<double>(), 1.0);
}

TEST(RegisterCli, JsonFileNamesWithQuotesBackslashesAndControlCharactersParseBack) {
  RegisterOptions o;
  o.source_path = std::string("dir\\\"x\"\\y\n\t\r\b\f\x01\x1f\x7f end.pcd");
  o.source_path += '\0';  // the embedded NUL of a std::string too
  o.source_path += "tail";
  o.target_path = "caf\xc3\xa9/\xe2\x82\xac.ply";  // UTF-8 passes through unchanged
  const std::string text = register_json(o, {}, {}, {}, {}, {});
  ASSERT_TRUE(nlohmann::json::accept(text)) << text;
  nlohmann::ordered_json j = parse_line(text);
  EXPECT_EQ(j["source"].get<std::string>(), o.source_path);
  EXPECT_EQ(j["target"].get<std::string>(), o.target_path);
}

TEST(RegisterCli, JsonStaysValidForFileNamesThatAreNotUtf8) {
  RegisterOptions o;
  o.source_path = "latin1_\xe9t\xe9.pcd";  // a Linux path may hold any bytes but '/' and NUL
  const std::string text = register_json(o, {}, {}, {}, {}, {});
  ASSERT_TRUE(nlohmann::json::accept(text)) << text;
  EXPECT_EQ(parse_line(text)["source"], "latin1_\xef\xbf\xbdt\xef\xbf\xbd.pcd");  // U+FFFD each
}

}  // namespace
}  // namespace v2xloc::tools
