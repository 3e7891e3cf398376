// Recordings whose trust list predates surveys: upgrade_trust_list (v2xloc-sim upgrade-trust)
// writes the list with each infrastructure unit's surveyed pose (from the manifest) beside the
// original and names it in the manifest; a second run has nothing to do; an infrastructure sensor
// without a signer is an error.
#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/recording/sim_trust.hpp"
#include "host_sim/recording/trust_list_upgrade.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <unistd.h>

namespace v2xloc::sim {
namespace {

namespace fs = std::filesystem;

class TrustListUpgradeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(V2XLOC_BINARY_DIR) / "test_tmp" / "trust_upgrade" / (std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    write("ground_truth.tum", "0 0 0 0 0 0 0 1\n");
    write("ground_truth_100hz.tum", "0 0 0 0 0 0 0 1\n0.01 0.1 0 0 0 0 0 1\n");
    survey_ = Eigen::Translation3d(9.5, -3.0, 5.0) * Eigen::AngleAxisd(2.3, Eigen::Vector3d::UnitZ());
    m_ = {{"format", "v2xloc-recording"},
          {"scenario", {{"id", 0}}},
          {"permutation", "2_infra"},
          {"frame_rate_hz", 10.0},
          {"frame_count", 1},
          {"time_origin_unix_s", 1700000000.0},
          {"geodetic_origin", {{"lat_deg", 48.1}, {"lon_deg", 11.5}, {"alt_m", 520.0}}},
          {"files",
           {{"ego_scan_pattern", "ego_lidar/%06d.pcd"},
            {"ground_truth", "ground_truth.tum"},
            {"ground_truth_100hz", "ground_truth_100hz.tum"},
            {"trust_list", "trust_list.txt"}}},
          {"sensors", Json::array({{{"name", "ego_lidar"}, {"mount_in_body", Json::array({0, 0, 1.9, 0, 0, 0, 1})}},
                                   {{"name", "infra_2"}, {"carrier", "infrastructure"},
                                    {"surveyed_pose_enu", pose_to_json(survey_)}}})},
          {"map_clouds", {{"clouds", Json::array()}}}};
    write("manifest.json", m_.dump(2));
    SimSigner infra, agent;
    ASSERT_TRUE(sim_signer("infra", "infra_2", infra));
    ASSERT_TRUE(sim_signer("agent", "agent_0_lidar", agent));
    old_text_ = trust_list_text(trust_list_of({infra, agent}));
    write("trust_list.txt", old_text_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  void write(const std::string& rel, const std::string& text) {
    std::string err;
    ASSERT_TRUE(write_text_file((dir_ / rel).string(), text, err)) << err;
  }
  std::string read(const std::string& rel) {
    std::string text, err;
    EXPECT_TRUE(read_text_file((dir_ / rel).string(), 1u << 20, text, err)) << err;
    return text;
  }

  fs::path dir_;
  Json m_;
  Eigen::Isometry3d survey_;
  std::string old_text_;
};

TEST_F(TrustListUpgradeTest, AddsTheSurveysBesideTheOriginal) {
  TrustListUpgrade r;
  std::string err;
  ASSERT_TRUE(upgrade_trust_list(dir_.string(), r, err)) << err;
  EXPECT_FALSE(r.already_surveyed);
  EXPECT_EQ(r.file, "trust_list_surveyed.txt");
  EXPECT_EQ(r.signers, 2u);
  EXPECT_EQ(r.surveyed, 1u);
  EXPECT_EQ(read("trust_list.txt"), old_text_);  // the original is kept
  EXPECT_EQ(Json::parse(read("manifest.json"))["files"]["trust_list"], "trust_list_surveyed.txt");
  trust::TrustList list;
  ASSERT_TRUE(load_trust_list((dir_ / r.file).string(), list, err)) << err;
  ASSERT_EQ(list.count, 2u);
  const trust::SurveyedPose want = surveyed_pose(survey_);
  ASSERT_TRUE(list.signers[0].surveyed);
  // Through the manifest's JSON and back into a rotation: equal to rounding.
  for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(list.signers[0].survey.position_m[i], want.position_m[i], 1e-12);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(list.signers[0].survey.quaternion_xyzw[i], want.quaternion_xyzw[i], 1e-12);
  EXPECT_FALSE(list.signers[1].surveyed);  // the agent

  TrustListUpgrade again;
  ASSERT_TRUE(upgrade_trust_list(dir_.string(), again, err)) << err;
  EXPECT_TRUE(again.already_surveyed);
  EXPECT_EQ(again.file, "trust_list_surveyed.txt");
}

TEST_F(TrustListUpgradeTest, InfrastructureWithoutASignerIsAnError) {
  SimSigner agent;
  ASSERT_TRUE(sim_signer("agent", "agent_0_lidar", agent));
  write("trust_list.txt", trust_list_text(trust_list_of({agent})));
  TrustListUpgrade r;
  std::string err;
  EXPECT_FALSE(upgrade_trust_list(dir_.string(), r, err));
  EXPECT_NE(err.find("infra_2"), std::string::npos) << err;
  EXPECT_EQ(Json::parse(read("manifest.json"))["files"]["trust_list"], "trust_list.txt");
}

}  // namespace
}  // namespace v2xloc::sim
