#include "v2xloc/algo/registration/ransac.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "registration_test_support.hpp"

namespace v2xloc {
namespace {

using testing::rotation_error_deg;
using testing::rotation_zyx;
using testing::translation_error;

// Target: random points in a 20 m box; source = truth^-1 * target + 1 cm noise; correspondences
// with a given fraction of correct pairs, the rest random.
struct Problem {
  std::vector<Vec3f> source, target;
  std::vector<Correspondence> corr;
  std::vector<std::uint32_t> indices;
  std::vector<KdNode> nodes;
  KdTree<Vec3f> tree;
  Mat4d truth;
};

void make_problem(Problem& p, double inlier_fraction, std::uint64_t seed) {
  Pcg32 rng(seed);
  p.truth = rotation_zyx(2.0, 0.05, -0.03, Vec3d(5.0, -3.0, 0.5));
  const Mat4d inv = p.truth.inverse();
  for (int i = 0; i < 1500; ++i) {
    const Vec3d q(rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(0, 5));
    p.target.push_back(q.cast<float>());
    const Vec3d s = inv.topLeftCorner<3, 3>() * q + inv.topRightCorner<3, 1>() +
                    Vec3d(rng.uniform(-0.01, 0.01), rng.uniform(-0.01, 0.01), rng.uniform(-0.01, 0.01));
    p.source.push_back(s.cast<float>());
  }
  for (std::uint32_t i = 0; i < p.source.size(); ++i) {
    const bool good = rng.uniform01() < inlier_fraction;
    p.corr.push_back({i, good ? i : rng.uniform_below(static_cast<std::uint32_t>(p.target.size()))});
  }
  p.indices.resize(p.target.size());
  p.nodes.resize(kd_max_nodes(p.target.size()));
  p.tree.build(p.target, p.indices, p.nodes);
}

TEST(Ransac, FindsTransformWithManyOutliersDeterministically) {
  Problem p;
  make_problem(p, 0.15, 21);
  RansacParams params;
  params.max_correspondence_distance = 0.05;
  params.distance_check_threshold = 0.05;
  params.seed = 1234;
  const RansacResult a = ransac(p.source, p.target, p.corr, p.tree, params);
  ASSERT_EQ(a.registration.status, RegistrationStatus::kOk);
  EXPECT_LT(translation_error(a.registration.transform, p.truth), 0.01);
  EXPECT_LT(rotation_error_deg(a.registration.transform, p.truth), 0.1);
  EXPECT_NEAR(a.correspondence_fitness, 0.15, 0.03);
  EXPECT_NEAR(a.registration.fitness, 1.0, 0.01);  // every source point has its target point
  EXPECT_GT(a.rejected_edge_length, 0u);           // the pre-rejection did work
  EXPECT_GT(a.validations, 0u);
  EXPECT_LE(a.validations, params.criteria.max_validations);
  // The confidence bound stopped the search well before the iteration cap.
  EXPECT_TRUE(a.registration.converged);
  EXPECT_LT(a.registration.iterations, config::kRansacMaxIterations);

  const RansacResult b = ransac(p.source, p.target, p.corr, p.tree, params);
  EXPECT_EQ(a.registration.transform, b.registration.transform);  // bit-identical
  EXPECT_EQ(a.registration.iterations, b.registration.iterations);
}

TEST(Ransac, CapsValidationsAndIterations) {
  Problem p;
  make_problem(p, 0.0, 22);  // no correct pair at all
  RansacParams params;
  params.max_correspondence_distance = 0.05;
  params.criteria.max_iterations = 3000;
  params.criteria.max_validations = 50;
  const RansacResult r = ransac(p.source, p.target, p.corr, p.tree, params);
  EXPECT_LE(r.validations, 50u);
  EXPECT_LE(r.registration.iterations, 3000u);
  EXPECT_TRUE(r.registration.transform.allFinite());
}

TEST(Ransac, TooFewOrInvalidCorrespondences) {
  Problem p;
  make_problem(p, 1.0, 23);
  RansacParams params;
  const std::vector<Correspondence> two = {{0, 0}, {1, 1}};
  EXPECT_EQ(ransac(p.source, p.target, two, p.tree, params).registration.status,
            RegistrationStatus::kNoCorrespondences);
  const std::vector<Correspondence> out_of_range = {{0, 0}, {1, 1}, {2, 99999}, {99999, 3}};
  const RansacResult r = ransac(p.source, p.target, out_of_range, p.tree, params);
  EXPECT_EQ(r.registration.status, RegistrationStatus::kNoCorrespondences);
  EXPECT_EQ(r.invalid_correspondences, 2u);
  params.max_correspondence_distance = 0.0;
  EXPECT_EQ(ransac(p.source, p.target, p.corr, p.tree, params).registration.status,
            RegistrationStatus::kInvalidInput);
}

}  // namespace
}  // namespace v2xloc
