#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "registration_test_support.hpp"
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/registration/register_clouds.hpp"

namespace v2xloc {
namespace {

using testing::rotation_error_deg;
using testing::rotation_zyx;
using testing::translation_error;

RegistrationWorkspace& workspace() {
  static RegistrationWorkspace ws;
  return ws;
}

// Issue 2, item 2: >= 50 seeded random transforms (yaw up to 180 deg, translation up to 10 m),
// urban-like pairs with 2 cm noise and 60-80 % overlap; >= 98 % within 5 cm / 0.5 deg.
TEST(RegistrationAccuracy, SyntheticUrbanPairsGlobalPlusIcp) {
  constexpr int kTrials = 50;
  Pcg32 rng(2026);
  testing::UrbanSceneOptions options;  // 2 cm noise
  options.sensor_range = 20.0;
  options.sensor_separation = 11.0;    // ~ 65-75 % of the source points seen by both
  RegisterCloudsParams params;
  params.voxel_size = 0.4f;
  int success = 0;
  double worst_t = 0.0, worst_r = 0.0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const Mat4d truth = testing::random_transform(rng, det::kPi, 0.03, 10.0);
    const testing::CloudPair pair = testing::make_urban_pair(100 + trial, 200 + trial, truth, options);
    ASSERT_GE(pair.overlap, 0.6);
    ASSERT_LE(pair.overlap, 0.8);
    const RegisterCloudsResult r =
        register_clouds(pair.source, pair.target, params, Mat4d::Identity(), workspace());
    const double te = translation_error(r.registration.transform, truth);
    const double re = rotation_error_deg(r.registration.transform, truth);
    const bool ok = r.registration.ok() && te <= 0.05 && re <= 0.5;
    success += ok ? 1 : 0;
    if (ok) {
      worst_t = te > worst_t ? te : worst_t;
      worst_r = re > worst_r ? re : worst_r;
    } else {
      std::printf("trial %d failed: %s te %.3f m re %.3f deg overlap %.2f\n", trial,
                  to_string(r.registration.status), te, re, pair.overlap);
    }
  }
  std::printf("synthetic: %d/%d succeeded, worst successful error %.4f m %.4f deg\n", success,
              kTrials, worst_t, worst_r);
  EXPECT_GE(success, 49);  // >= 98 %
}

std::string data_dir() { return std::string(V2XLOC_SHARED_DATA_DIR); }

// tests/data/outdoor_lidar_pair (V2XLOC_SHARED_DATA_DIR): both scans and the reference p_target = T p_source.
void load_outdoor_pair(const std::string& dir, std::vector<Vec3f>& source, std::vector<Vec3f>& target,
                       Mat4d& reference) {
  std::string error;
  ASSERT_TRUE(testing::read_ply_xyz(dir + "/source.ply", source, error)) << error;
  ASSERT_TRUE(testing::read_ply_xyz(dir + "/target.ply", target, error)) << error;
  ASSERT_TRUE(testing::read_matrix4(dir + "/T_target_source.txt", reference, error)) << error;
}

// Issue 2, item 2: the real scans, from >= 20 seeded initial offsets (up to 5 m, 30 deg), global
// pipeline then ICP, within 5 cm / 0.5 deg of the reference transform.
TEST(RegistrationAccuracy, OutdoorLidarPairFromPerturbedStarts) {
  const std::string dir = data_dir() + "/outdoor_lidar_pair";
  if (!testing::file_exists(dir + "/source.ply")) GTEST_SKIP() << "no data at " << dir;
  std::vector<Vec3f> source, target;
  Mat4d reference;
  load_outdoor_pair(dir, source, target, reference);
  if (HasFatalFailure()) return;
  RegisterCloudsParams params;
  params.voxel_size = 0.25f;
  constexpr int kTrials = 20;
  Pcg32 rng(77);
  int success = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    // Perturb the source: p_perturbed = P p_source, so the answer is reference * P^-1.
    const Mat4d perturbation = testing::random_transform(rng, 30.0 * det::kPi / 180.0, 0.0, 5.0);
    const std::vector<Vec3f> moved = testing::transform_cloud(source, perturbation);
    const Mat4d truth = reference * perturbation.inverse();
    params.ransac.seed = 1000 + static_cast<std::uint64_t>(trial);
    const RegisterCloudsResult r =
        register_clouds(moved, target, params, Mat4d::Identity(), workspace());
    const double te = translation_error(r.registration.transform, truth);
    const double re = rotation_error_deg(r.registration.transform, truth);
    const bool ok = r.registration.ok() && te <= 0.05 && re <= 0.5;
    success += ok ? 1 : 0;
    std::printf("outdoor trial %2d: %s te %.4f m re %.4f deg fitness %.3f rmse %.3f\n", trial,
                to_string(r.registration.status), te, re, r.registration.fitness,
                r.registration.inlier_rmse);
  }
  EXPECT_EQ(success, kTrials);
}

// Voxel 0.5 m: the final ICP (1-voxel gate) must settle on the true pose, not in the 1.2 deg
// limit cycle that plain least squares falls into from about half of the RANSAC starts (the
// outliers inside the 0.5 m gate pull it; Tukey's kernel at 0.5 voxel ignores them). Several
// RANSAC seeds give different coarse starts (0.3-0.9 deg off).
TEST(RegistrationAccuracy, OutdoorLidarPairAtVoxelHalfMetreConvergesOnTruePose) {
  const std::string dir = data_dir() + "/outdoor_lidar_pair";
  if (!testing::file_exists(dir + "/source.ply")) GTEST_SKIP() << "no data at " << dir;
  std::vector<Vec3f> source, target;
  Mat4d reference;
  load_outdoor_pair(dir, source, target, reference);
  if (HasFatalFailure()) return;
  RegisterCloudsParams params;
  params.voxel_size = 0.5f;
  int plain_failures = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    params.ransac.seed = seed;
    params.icp.kernel.type = RobustKernelType::kTukey;
    const RegisterCloudsResult r =
        register_clouds(source, target, params, Mat4d::Identity(), workspace());
    const double te = translation_error(r.registration.transform, reference);
    const double re = rotation_error_deg(r.registration.transform, reference);
    std::printf("voxel 0.5 seed %d: coarse %.3f deg, final %s te %.4f m re %.3f deg, %u ICP "
                "iterations%s\n",
                int(seed), rotation_error_deg(r.coarse.transform, reference),
                to_string(r.registration.status), te, re, r.registration.iterations,
                r.registration.converged ? "" : " (cap)");
    EXPECT_TRUE(r.registration.ok());
    EXPECT_TRUE(r.registration.converged) << seed;
    EXPECT_LE(te, 0.05) << seed;
    EXPECT_LE(re, 0.5) << seed;
    // The same start without the kernel, for the record (not asserted: depends on the start).
    params.icp.kernel.type = RobustKernelType::kNone;
    const RegisterCloudsResult plain =
        register_clouds(source, target, params, Mat4d::Identity(), workspace());
    plain_failures += rotation_error_deg(plain.registration.transform, reference) > 0.5 ? 1 : 0;
  }
  std::printf("voxel 0.5, plain least-squares ICP from the same starts: %d/8 end > 0.5 deg off\n",
              plain_failures);
}

// ICP on the bunny pair against PCL's own regression reference (an algorithm output, not ground
// truth), point-to-point like PCL's test, 5 cm gate.
TEST(RegistrationAccuracy, BunnyPairIcpNearPclReference) {
  const std::string dir = data_dir() + "/bunny_pair";
  if (!testing::file_exists(dir + "/bun0.pcd")) GTEST_SKIP() << "no data at " << dir;
  std::vector<Vec3f> bun0, bun4;
  Mat4d reference;
  std::string error;
  ASSERT_TRUE(testing::read_pcd_ascii_xyz(dir + "/bun0.pcd", bun0, error)) << error;
  ASSERT_TRUE(testing::read_pcd_ascii_xyz(dir + "/bun4.pcd", bun4, error)) << error;
  ASSERT_TRUE(testing::read_matrix4(dir + "/T_bun4_from_bun0_pcl_reference.txt", reference, error))
      << error;
  ASSERT_EQ(bun0.size(), 397u);
  ASSERT_EQ(bun4.size(), 361u);
  std::vector<std::uint32_t> indices(bun4.size());
  std::vector<KdNode> nodes(kd_max_nodes(bun4.size()));
  KdTree<Vec3f> tree;
  tree.build(bun4, indices, nodes);
  IcpTarget view;
  view.points = bun4;
  view.tree = &tree;
  IcpParams params;
  params.method = IcpMethod::kPointToPoint;
  params.max_correspondence_distance = 0.05;
  params.criteria.max_iterations = 50;
  params.criteria.relative_fitness = 1e-8;
  params.criteria.relative_rmse = 1e-8;
  const RegistrationResult r = icp(bun0, view, Mat4d::Identity(), params);
  ASSERT_EQ(r.status, RegistrationStatus::kOk);
  const double te = translation_error(r.transform, reference);
  const double re = rotation_error_deg(r.transform, reference);
  std::printf("bunny: te %.6f m re %.5f deg fitness %.3f rmse %.4f iterations %u\n", te, re,
              r.fitness, r.inlier_rmse, r.iterations);
  // PCL accepts 1e-3 per matrix entry against its own implementation; ours differs in
  // correspondence handling, so allow a few mm / ~1 deg on a 15 cm object.
  EXPECT_LT(te, 0.01);
  EXPECT_LT(re, 1.5);
  EXPECT_LT(r.inlier_rmse, 0.01);
}

}  // namespace
}  // namespace v2xloc
