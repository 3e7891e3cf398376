// Recordings whose trust list predates surveys: upgrade_trust_list (v2xloc-sim upgrade-trust)
// writes the list with each infrastructure unit's surveyed pose (from the manifest), and on request
// its surveyed background, beside the original and names it in the manifest; a second run has
// nothing to do; an infrastructure sensor without a signer is an error.
#include "firmware/trust/background_file.hpp"
#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/recording/sim_trust.hpp"
#include "host_sim/recording/trust_list_upgrade.hpp"
#include "recording_dir_test.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "v2xloc/algo/core/config.hpp"

namespace v2xloc::sim {
namespace {

class TrustListUpgradeTest : public test::RecordingDirTest {
 protected:
  void SetUp() override {
    make_recording("trust_upgrade");
    survey_ = Eigen::Translation3d(9.5, -3.0, 5.0) * Eigen::AngleAxisd(2.3, Eigen::Vector3d::UnitZ());
    m_["files"]["trust_list"] = "trust_list.txt";
    m_["sensors"].push_back({{"name", "infra_2"}, {"carrier", "infrastructure"}, {"surveyed_pose_enu", pose_to_json(survey_)}});
    write("manifest.json", m_.dump(2));
    SimSigner infra, agent;
    ASSERT_TRUE(sim_signer("infra", "infra_2", infra));
    ASSERT_TRUE(sim_signer("agent", "agent_0_lidar", agent));
    old_text_ = trust_list_text(trust_list_of({infra, agent}));
    write("trust_list.txt", old_text_);
  }

  Eigen::Isometry3d survey_;
  std::string old_text_;
};

TEST_F(TrustListUpgradeTest, AddsTheSurveysBesideTheOriginal) {
  TrustListUpgrade r;
  std::string err;
  ASSERT_TRUE(upgrade_trust_list(dir_.string(), false, r, err)) << err;
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
  ASSERT_TRUE(upgrade_trust_list(dir_.string(), false, again, err)) << err;
  EXPECT_TRUE(again.already_surveyed);
  EXPECT_EQ(again.file, "trust_list_surveyed.txt");
}

TEST_F(TrustListUpgradeTest, AddsSurveysAndBackgrounds) {
  TrustListUpgrade r;
  std::string err;
  ASSERT_TRUE(upgrade_trust_list(dir_.string(), true, r, err)) << err;
  EXPECT_EQ(r.file, "trust_list_background.txt");
  EXPECT_EQ(r.surveyed, 1u);
  EXPECT_EQ(r.backgrounds, 1u);
  EXPECT_EQ(read("trust_list.txt"), old_text_);
  trust::TrustList list;
  ASSERT_TRUE(load_trust_list((dir_ / r.file).string(), list, err)) << err;
  const trust::TrustedSigner& infra = list.signers[0];
  ASSERT_TRUE(infra.surveyed);
  ASSERT_TRUE(infra.has_background);
  EXPECT_STREQ(infra.background_file.data(), "background_infra_2.bin");
  EXPECT_FALSE(list.signers[1].has_background);  // the agent
  // The file is the one the list vouches for, and the firmware's parser takes it.
  const std::string file = read(infra.background_file.data());
  std::vector<std::uint32_t> cells(config::kBackgroundFileCells);
  trust::BackgroundInfo info;
  ASSERT_EQ(trust::parse_background({reinterpret_cast<const std::uint8_t*>(file.data()), file.size()}, infra, cells, info),
            trust::BackgroundStatus::kOk);
  EXPECT_EQ(info.sender_id, 3u);
  EXPECT_GT(info.cells, 1000u);  // a 32-beam unit's scene
  EXPECT_GE(info.cell_m, 0.1);

  TrustListUpgrade again;  // has everything: nothing to do; surveys only: nothing either
  ASSERT_TRUE(upgrade_trust_list(dir_.string(), true, again, err)) << err;
  EXPECT_TRUE(again.already_surveyed);
  EXPECT_EQ(again.backgrounds, 1u);
  ASSERT_TRUE(upgrade_trust_list(dir_.string(), false, again, err)) << err;
  EXPECT_TRUE(again.already_surveyed);
}

TEST_F(TrustListUpgradeTest, InfrastructureWithoutASignerIsAnError) {
  SimSigner agent;
  ASSERT_TRUE(sim_signer("agent", "agent_0_lidar", agent));
  write("trust_list.txt", trust_list_text(trust_list_of({agent})));
  TrustListUpgrade r;
  std::string err;
  EXPECT_FALSE(upgrade_trust_list(dir_.string(), false, r, err));
  EXPECT_NE(err.find("infra_2"), std::string::npos) << err;
  EXPECT_EQ(Json::parse(read("manifest.json"))["files"]["trust_list"], "trust_list.txt");
}

}  // namespace
}  // namespace v2xloc::sim
