#include "tools/eval/paper_table.hpp"
#include "host_sim/eval/trajectory.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <string>

#include <cmath>
#include <cstdio>
#include <filesystem>

namespace v2xloc::sim {
namespace {

StampedTrajectory make_curve(std::size_t n) {
  StampedTrajectory t;
  for (std::size_t i = 0; i < n; ++i) {
    StampedPose p;
    p.t = 0.1 * static_cast<double>(i);
    p.position = {10.0 * std::cos(0.05 * i), 5.0 * std::sin(0.07 * i), 0.01 * i};
    p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * i, Eigen::Vector3d::UnitZ()));
    t.push_back(p);
  }
  return t;
}

TEST(StampedTrajectory, TumRoundTrip) {
  const auto path = std::filesystem::temp_directory_path() / ("v2xloc_tum_roundtrip_" + std::to_string(::getpid()) + ".tum");
  const StampedTrajectory in = make_curve(50);
  std::string error;
  ASSERT_TRUE(write_tum(path.string(), in, error)) << error;
  StampedTrajectory out;
  ASSERT_TRUE(read_tum(path.string(), out, error)) << error;
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    EXPECT_NEAR(out[i].t, in[i].t, 1e-6);
    EXPECT_NEAR((out[i].position - in[i].position).norm(), 0.0, 1e-5);
    EXPECT_NEAR(out[i].orientation.angularDistance(in[i].orientation), 0.0, 1e-6);
  }
  std::filesystem::remove(path);
}

TEST(StampedTrajectory, MalformedTumIsAnErrorWithLineNumber) {
  const auto path = std::filesystem::temp_directory_path() / ("v2xloc_tum_bad_" + std::to_string(::getpid()) + ".tum");
  std::FILE* f = std::fopen(path.string().c_str(), "w");
  std::fputs("# header\n0 1 2 3 0 0 0 1\n0.1 1 2\n", f);
  std::fclose(f);
  StampedTrajectory out;
  std::string error;
  EXPECT_FALSE(read_tum(path.string(), out, error));
  EXPECT_NE(error.find(":3:"), std::string::npos) << error;
  std::filesystem::remove(path);
}

TEST(StampedTrajectory, UmeyamaRecoversRigidTransform) {
  const StampedTrajectory ref = make_curve(100);
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  offset.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.1, 0.2, 1.0).normalized()).toRotationMatrix();
  offset.translation() = Eigen::Vector3d(3.0, -7.0, 0.5);
  StampedTrajectory est = ref;
  for (auto& p : est) p.position = offset * p.position;
  const ErrorStats raw = absolute_position_error(est, ref, false);
  const ErrorStats aligned = absolute_position_error(est, ref, true);
  EXPECT_EQ(raw.count, 100u);
  EXPECT_GT(raw.mean, 1.0);
  EXPECT_LT(aligned.max, 1e-9);
}

TEST(StampedTrajectory, AssociationToleratesMissingAndJitteredStamps) {
  const StampedTrajectory ref = make_curve(20);
  StampedTrajectory est;
  for (std::size_t i = 0; i < ref.size(); i += 2) {
    StampedPose p = ref[i];
    p.t += 0.002;
    est.push_back(p);
  }
  const auto pairs = associate(est, ref, 0.005);
  ASSERT_EQ(pairs.size(), 10u);
  for (std::size_t k = 0; k < pairs.size(); ++k) EXPECT_EQ(pairs[k].second, 2 * k);
  EXPECT_TRUE(associate(est, ref, 0.001).empty());
}

TEST(StampedTrajectory, ErrorStats) {
  const ErrorStats s = error_stats({3.0, 1.0, 2.0, 4.0});
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_NEAR(s.rmse, std::sqrt(7.5), 1e-12);
}

TEST(PaperTable, HasAllTwelveRows) {
  for (int sim = 0; sim < 4; ++sim) {
    for (const char* perm : {"4_infra_2_agent", "4_infra", "2_infra"}) {
      EXPECT_NE(find_paper_row(sim, perm), nullptr) << sim << perm;
    }
  }
  EXPECT_DOUBLE_EQ(find_paper_row(2, "4_infra")->reg, 32.530);
}

}  // namespace
}  // namespace v2xloc::sim
