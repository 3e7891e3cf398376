#include "v2xloc/algo/registration/icp.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "registration_test_support.hpp"
#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/registration/voxel_downsample.hpp"

namespace v2xloc {
namespace {

using testing::rotation_error_deg;
using testing::rotation_zyx;
using testing::translation_error;

// A target cloud with its tree and normals, held in heap storage (test side).
struct TargetMap {
  explicit TargetMap(std::vector<Vec3f> pts) : points(std::move(pts)) {
    indices.resize(points.size());
    nodes.resize(kd_max_nodes(points.size()));
    normals.resize(points.size());
    tree.build(points, indices, nodes);
    NormalParams np;
    np.radius = 1.0f;
    np.viewpoint = Vec3f(0, 0, 1.8f);
    estimate_normals(tree, np, normals);
  }
  IcpTarget view(bool with_normals = true) const {
    IcpTarget v;
    v.points = points;
    if (with_normals) v.normals = normals;
    v.tree = &tree;
    return v;
  }
  std::vector<Vec3f> points;
  std::vector<std::uint32_t> indices;
  std::vector<KdNode> nodes;
  std::vector<Vec3f> normals;
  KdTree<Vec3f> tree;
};

testing::UrbanSceneOptions small_scene() {
  testing::UrbanSceneOptions o;
  o.sensor_range = 16.0;
  o.sensor_separation = 5.0;
  o.ground_density = 6.0;
  o.structure_density = 12.0;
  return o;
}

// Voxel centroids (0.3 m) as the pipeline feeds ICP: averages the 2 cm noise and the random
// sampling, so the result is limited by the geometry, not by the sample spacing.
std::vector<Vec3f> downsample(const std::vector<Vec3f>& cloud) {
  static VoxelDownsampleStorage<1u << 16, 16384> storage;
  static FixedVector<Vec3f, 16384> out;
  storage.run(cloud, 0.3f, out);
  return std::vector<Vec3f>(out.begin(), out.end());
}

TEST(RobustKernel, WeightsFollowTheirDefinitions) {
  RobustKernel k;
  k.scale = 0.1;
  k.type = RobustKernelType::kNone;
  EXPECT_DOUBLE_EQ(k.weight(5.0), 1.0);
  k.type = RobustKernelType::kHuber;
  EXPECT_DOUBLE_EQ(k.weight(0.05), 1.0);
  EXPECT_DOUBLE_EQ(k.weight(-0.4), 0.25);
  k.type = RobustKernelType::kTukey;
  EXPECT_DOUBLE_EQ(k.weight(0.0), 1.0);
  EXPECT_DOUBLE_EQ(k.weight(0.2), 0.0);
  EXPECT_NEAR(k.weight(0.05), 0.5625, 1e-15);
  k.type = RobustKernelType::kCauchy;
  EXPECT_DOUBLE_EQ(k.weight(0.1), 0.5);
  k.type = RobustKernelType::kGemanMcClure;
  EXPECT_DOUBLE_EQ(k.weight(0.0), 1.0);
  EXPECT_DOUBLE_EQ(k.weight(0.1), 0.25);
}

class IcpConvergence : public ::testing::TestWithParam<IcpMethod> {};

TEST_P(IcpConvergence, RecoversSmallOffsetOnUrbanScene) {
  const Mat4d truth = rotation_zyx(0.03, 0.01, -0.01, Vec3d(0.25, -0.15, 0.05));
  const testing::CloudPair pair = testing::make_urban_pair(5, 6, truth, small_scene());
  const TargetMap map(downsample(pair.target));
  const std::vector<Vec3f> source = downsample(pair.source);
  IcpParams params;
  params.method = GetParam();
  params.max_correspondence_distance = 0.5;
  params.criteria.max_iterations = 60;
  const RegistrationResult r = icp(source, map.view(), Mat4d::Identity(), params);
  ASSERT_EQ(r.status, RegistrationStatus::kOk) << to_string(r.status);
  // Point-to-point slides along planes and keeps some of the voxel-centroid sampling bias.
  const bool plane = GetParam() == IcpMethod::kPointToPlane;
  EXPECT_LT(translation_error(r.transform, truth), plane ? 0.02 : 0.05);
  EXPECT_LT(rotation_error_deg(r.transform, truth), 0.3);
  EXPECT_GT(r.fitness, 0.5);
  EXPECT_GT(r.inliers, 0u);
  EXPECT_LT(r.inlier_rmse, 0.25);  // centroids of independently sampled 0.3 m voxels
  EXPECT_GT(r.iterations, 1u);
  // Information (Open3D meaning): symmetric, translation block = inliers * I.
  EXPECT_LT((r.information - r.information.transpose()).norm(), 1e-6 * r.information.norm());
  EXPECT_DOUBLE_EQ(r.information(3, 3), double(r.inliers));
  EXPECT_DOUBLE_EQ(r.information(5, 5), double(r.inliers));
  // Matches evaluate_registration at the returned transform.
  const RegistrationResult e = evaluate_registration(source, map.view(), r.transform, 0.5);
  EXPECT_EQ(e.inliers, r.inliers);
  EXPECT_DOUBLE_EQ(e.fitness, r.fitness);
  EXPECT_DOUBLE_EQ(e.inlier_rmse, r.inlier_rmse);
}

INSTANTIATE_TEST_SUITE_P(Methods, IcpConvergence,
                         ::testing::Values(IcpMethod::kPointToPoint, IcpMethod::kPointToPlane));

// A search spread over several periods runs its ICPs a few passes at a time: the sliced run
// must end with exactly icp()'s result, and count its passes.
TEST(Icp, SlicedRunIsBitIdenticalToOneCall) {
  const Mat4d truth = rotation_zyx(0.03, 0.01, -0.01, Vec3d(0.25, -0.15, 0.05));
  const testing::CloudPair pair = testing::make_urban_pair(5, 6, truth, small_scene());
  const TargetMap map(downsample(pair.target));
  const std::vector<Vec3f> source = downsample(pair.source);
  for (const IcpMethod method : {IcpMethod::kPointToPlane, IcpMethod::kPointToPoint}) {
    IcpParams params;
    params.method = method;
    params.max_correspondence_distance = 0.5;
    params.criteria.max_iterations = 40;
    std::vector<std::uint32_t> hints_a(source.size()), hints_b(source.size());
    const RegistrationResult whole = icp(source, map.view(), Mat4d::Identity(), params, hints_a);
    IcpRun run;
    icp_begin(run, source, map.view(), Mat4d::Identity(), params, hints_b);
    int calls = 0;
    while (!icp_continue(run, source, map.view(), params, 2, hints_b)) ASSERT_LT(++calls, 100);
    EXPECT_GT(calls, 1);
    EXPECT_EQ(run.passes, whole.iterations + 1) << "one pass per update plus the final evaluation";
    EXPECT_EQ(run.result.status, whole.status);
    EXPECT_EQ(run.result.iterations, whole.iterations);
    EXPECT_EQ(run.result.inliers, whole.inliers);
    EXPECT_EQ(run.result.fitness, whole.fitness);
    EXPECT_EQ(run.result.inlier_rmse, whole.inlier_rmse);
    EXPECT_TRUE(run.result.transform == whole.transform);
    EXPECT_EQ(hints_a, hints_b);
  }
  // Bad input finishes in icp_begin with icp()'s status.
  IcpRun bad;
  icp_begin(bad, source, IcpTarget{}, Mat4d::Identity(), IcpParams{});
  EXPECT_TRUE(bad.finished);
  EXPECT_EQ(bad.result.status, RegistrationStatus::kInvalidInput);
  EXPECT_TRUE(icp_continue(bad, source, IcpTarget{}, IcpParams{}, 5));
}

// A vicinity bitmap over the target lets queries with nothing within the gate skip the tree:
// the same bits, and only when the gate is within its reach.
TEST(Icp, VicinitySkipGivesTheSameResult) {
  const Mat4d truth = rotation_zyx(0.03, 0.01, -0.01, Vec3d(0.25, -0.15, 0.05));
  const testing::CloudPair pair = testing::make_urban_pair(5, 6, truth, small_scene());
  const TargetMap map(downsample(pair.target));
  std::vector<Vec3f> source = downsample(pair.source);
  for (int k = 0; k < 200; ++k) source.push_back(Vec3f(100.0f + k, -50.0f, 3.0f));  // nothing near
  Vec3d lo = Vec3d::Constant(1e9), hi = Vec3d::Constant(-1e9);
  for (const Vec3f& p : map.points) {
    lo = lo.cwiseMin(p.cast<double>());
    hi = hi.cwiseMax(p.cast<double>());
  }
  static ProximityGrid vicinity;
  vicinity.build(map.points, 0.5 * (lo + hi), 0.5 * (hi - lo), {0.5f, 1.01f});
  ASSERT_TRUE(vicinity.ready() && vicinity.valid());
  IcpTarget with = map.view();
  with.vicinity = &vicinity;
  for (const double gate : {1.0, 2.0}) {  // 2 m: beyond the reach, the tree answers all
    IcpParams params;
    params.max_correspondence_distance = gate;
    params.criteria.max_iterations = 40;
    std::vector<std::uint32_t> hints_a(source.size()), hints_b(source.size());
    const RegistrationResult a = icp(source, map.view(), Mat4d::Identity(), params, hints_a);
    const RegistrationResult b = icp(source, with, Mat4d::Identity(), params, hints_b);
    ASSERT_TRUE(a.ok());
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_EQ(a.inliers, b.inliers);
    EXPECT_EQ(a.fitness, b.fitness);
    EXPECT_EQ(a.inlier_rmse, b.inlier_rmse);
    EXPECT_TRUE(a.transform == b.transform);
    EXPECT_TRUE(a.information == b.information);
  }
}

TEST(Icp, RobustKernelDownWeightsOutliers) {
  const Mat4d truth = rotation_zyx(0.01, 0.0, 0.0, Vec3d(0.08, 0.05, 0.0));
  testing::UrbanSceneOptions o;
  o.sensor_range = 12.0;
  o.sensor_separation = 3.0;
  o.ground_density = 8.0;
  o.structure_density = 16.0;
  testing::CloudPair pair = testing::make_urban_pair(8, 9, truth, o);
  const TargetMap map(pair.target);
  // 30 % of the source points pushed 0.4 m up (in the target frame): all within the 1 m gate,
  // so plain least squares is pulled upwards.
  const Mat4d inv = truth.inverse();
  for (std::size_t i = 0; i < pair.source.size(); i += 3) {
    pair.source[i] += (inv.topLeftCorner<3, 3>() * Vec3d(0.0, 0.0, 0.4)).cast<float>();
  }
  IcpParams params;
  params.method = IcpMethod::kPointToPlane;
  params.max_correspondence_distance = 1.0;
  params.criteria.max_iterations = 60;
  const RegistrationResult plain = icp(pair.source, map.view(), Mat4d::Identity(), params);
  const double plain_error = translation_error(plain.transform, truth);
  for (RobustKernelType type : {RobustKernelType::kHuber, RobustKernelType::kTukey,
                                RobustKernelType::kCauchy, RobustKernelType::kGemanMcClure}) {
    params.kernel.type = type;
    params.kernel.scale = 0.1;
    const RegistrationResult robust = icp(pair.source, map.view(), Mat4d::Identity(), params);
    ASSERT_EQ(robust.status, RegistrationStatus::kOk);
    const double robust_error = translation_error(robust.transform, truth);
    EXPECT_LT(robust_error, 0.5 * plain_error) << int(type) << " plain " << plain_error;
    if (type != RobustKernelType::kHuber) {
      EXPECT_LT(robust_error, 0.03) << int(type);
    }
  }
  EXPECT_GT(plain_error, 0.04);  // the outliers really do bias plain least squares
}

TEST(Icp, SinglePlaneIsDegenerateNotNaN) {
  std::vector<Vec3f> plane;
  Pcg32 rng(4);
  for (int i = 0; i < 2000; ++i) {
    plane.emplace_back(float(rng.uniform(-10, 10)), float(rng.uniform(-10, 10)), 0.0f);
  }
  const TargetMap map(plane);
  IcpParams params;
  params.method = IcpMethod::kPointToPlane;
  const Mat4d init = rotation_zyx(0.0, 0.0, 0.0, Vec3d(0.1, 0.1, 0.2));
  const RegistrationResult r = icp(plane, map.view(), init, params);
  EXPECT_EQ(r.status, RegistrationStatus::kDegenerate);
  EXPECT_TRUE(r.transform.allFinite());
}

TEST(Icp, RejectsBadInputWithStatuses) {
  std::vector<Vec3f> pts = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  const TargetMap map(pts);
  IcpParams params;
  params.method = IcpMethod::kPointToPlane;
  IcpTarget no_tree = map.view();
  no_tree.tree = nullptr;
  EXPECT_EQ(icp(pts, no_tree, Mat4d::Identity(), params).status, RegistrationStatus::kInvalidInput);
  EXPECT_EQ(icp(pts, map.view(false), Mat4d::Identity(), params).status,
            RegistrationStatus::kInvalidInput);  // point-to-plane without normals
  params.max_correspondence_distance = -1.0;
  EXPECT_EQ(icp(pts, map.view(), Mat4d::Identity(), params).status, RegistrationStatus::kInvalidInput);
  params.max_correspondence_distance = 1.0;
  const std::vector<Vec3f> two(pts.begin(), pts.begin() + 2);
  EXPECT_EQ(icp(two, map.view(), Mat4d::Identity(), params).status,
            RegistrationStatus::kNotEnoughPoints);
  const Mat4d far = rotation_zyx(0, 0, 0, Vec3d(100, 0, 0));
  const RegistrationResult r = icp(pts, map.view(), far, params);
  EXPECT_EQ(r.status, RegistrationStatus::kNoCorrespondences);
  EXPECT_EQ(r.transform, far);
  EXPECT_EQ(r.fitness, 0.0);
  EXPECT_EQ(r.inlier_rmse, 0.0);
}

// A street between two facades: point-to-plane ICP matches only walls facing across it and the
// road, so nothing holds the pose along the street (horizontal_constraint ~ 0); a cross wall at
// the street's end does (the start-up search refuses solutions below its threshold).
std::vector<Vec3f> street(bool cross_wall) {
  std::vector<Vec3f> pts;
  for (float x = -20.0f; x <= 20.0f; x += 0.25f) {
    for (float y = -5.0f; y <= 5.0f; y += 0.25f) pts.emplace_back(x, y, 0.0f);  // road
    for (float z = 0.25f; z <= 4.0f; z += 0.25f) {
      pts.emplace_back(x, -5.0f, z);  // facades
      pts.emplace_back(x, 5.0f, z);
    }
  }
  if (cross_wall) {
    for (float y = -5.0f; y <= 5.0f; y += 0.25f) {
      for (float z = 0.25f; z <= 4.0f; z += 0.25f) pts.emplace_back(12.0f, y, z);
    }
  }
  return pts;
}

TEST(Icp, HorizontalConstraintSeesAnUnconstrainedStreet) {
  IcpParams params;
  params.method = IcpMethod::kPointToPlane;
  params.max_correspondence_distance = 1.0;
  params.criteria.max_iterations = 30;
  const Mat4d offset = rotation_zyx(0.01, 0.0, 0.0, Vec3d(0.2, 0.15, 0.05));
  double measured[2] = {0.0, 0.0};
  for (const bool cross : {false, true}) {
    const TargetMap map(street(cross));
    std::vector<Vec3f> source;
    for (std::size_t i = 0; i < map.points.size(); i += 3) {
      source.push_back((offset.topLeftCorner<3, 3>() * map.points[i].cast<double>() + offset.topRightCorner<3, 1>())
                           .cast<float>());
    }
    const RegistrationResult r = icp(source, map.view(), Mat4d::Identity(), params);
    ASSERT_EQ(r.status, RegistrationStatus::kOk) << to_string(r.status);
    EXPECT_GE(r.horizontal_constraint, 0.0);
    EXPECT_LE(r.horizontal_constraint, 0.5);
    measured[cross ? 1 : 0] = r.horizontal_constraint;
  }
  EXPECT_LT(measured[0], 0.005) << "facades along x and the road leave x free";
  EXPECT_GT(measured[1], 0.04) << "the cross wall holds x";
  // Other methods carry no point-to-plane system.
  params.method = IcpMethod::kPointToPoint;
  const TargetMap map(street(true));
  EXPECT_EQ(icp(map.points, map.view(false), Mat4d::Identity(), params).horizontal_constraint, 0.0);
}

}  // namespace
}  // namespace v2xloc
