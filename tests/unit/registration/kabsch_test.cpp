#include "v2xloc/algo/registration/kabsch.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "registration_test_support.hpp"

namespace v2xloc {
namespace {

using testing::rotation_error_deg;
using testing::rotation_zyx;
using testing::translation_error;

std::vector<Vec3f> random_points(Pcg32& rng, int n, double extent) {
  std::vector<Vec3f> pts;
  for (int i = 0; i < n; ++i) {
    pts.emplace_back(float(rng.uniform(-extent, extent)), float(rng.uniform(-extent, extent)),
                     float(rng.uniform(-extent, extent)));
  }
  return pts;
}

TEST(Kabsch, RecoversExactTransform) {
  Pcg32 rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const Mat4d truth = testing::random_transform(rng, 3.1, 1.0, 50.0);
    const std::vector<Vec3f> src = random_points(rng, 3 + trial * 5, 10.0);
    const std::vector<Vec3f> dst = testing::transform_cloud(src, truth);
    Mat4d est;
    ASSERT_EQ(kabsch_fit(src, dst, {}, est), RegistrationStatus::kOk);
    EXPECT_LT(translation_error(est, truth), 1e-4);   // float storage of the points
    EXPECT_LT(rotation_error_deg(est, truth), 1e-4);
    EXPECT_NEAR((est.topLeftCorner<3, 3>().determinant()), 1.0, 1e-12);
  }
}

TEST(Kabsch, LargeCoordinatesStayAccurate) {
  // Map-frame coordinates (km) must not cancel: sums are taken relative to the first pair.
  Pcg32 rng(2);
  std::vector<Vec3f> src = random_points(rng, 50, 20.0);
  for (Vec3f& p : src) p += Vec3f(3000.0f, -2000.0f, 50.0f);
  const Mat4d truth = rotation_zyx(0.3, 0.01, -0.02, Vec3d(1.5, -2.0, 0.1));
  std::vector<Vec3d> dst_d;
  Mat4d est;
  KabschAccumulator acc;
  for (const Vec3f& p : src) {
    const Vec3d pd = p.cast<double>();
    acc.add(pd, Vec3d(truth.topLeftCorner<3, 3>() * pd + truth.topRightCorner<3, 1>()));
  }
  ASSERT_EQ(acc.solve(est), RegistrationStatus::kOk);
  EXPECT_LT(translation_error(est, truth), 1e-8);
  EXPECT_LT(rotation_error_deg(est, truth), 1e-9);
}

TEST(Kabsch, NeverReturnsAReflection) {
  // Planar, mirrored target: the unconstrained optimum is a reflection; Kabsch must return a
  // proper rotation (det +1).
  std::vector<Vec3f> src = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 0.5f, 0}};
  std::vector<Vec3f> dst;
  for (const Vec3f& p : src) dst.emplace_back(-p.x(), p.y(), p.z());
  Mat4d est;
  ASSERT_EQ(kabsch_fit(src, dst, {}, est), RegistrationStatus::kOk);
  EXPECT_NEAR((est.topLeftCorner<3, 3>().determinant()), 1.0, 1e-12);
}

TEST(Kabsch, WeightsSelectTheConsistentSubset) {
  Pcg32 rng(3);
  const Mat4d truth = rotation_zyx(1.0, 0.0, 0.0, Vec3d(1, 2, 3));
  std::vector<Vec3f> src = random_points(rng, 30, 5.0);
  std::vector<Vec3f> dst = testing::transform_cloud(src, truth);
  std::vector<double> w(src.size(), 1.0);
  for (std::size_t i = 0; i < 10; ++i) {
    dst[i] += Vec3f(5.0f, 0.0f, 0.0f);  // outliers ...
    w[i] = 0.0;                         // ... given zero weight
  }
  Mat4d est;
  std::uint32_t skipped = 0;
  ASSERT_EQ(kabsch_fit(src, dst, w, est, {}, &skipped), RegistrationStatus::kOk);
  EXPECT_EQ(skipped, 10u);
  EXPECT_LT(translation_error(est, truth), 1e-4);
}

TEST(Kabsch, DegenerateInputsGiveStatuses) {
  Mat4d est = Mat4d::Identity();
  const std::vector<Vec3f> two = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_EQ(kabsch_fit(two, two, {}, est), RegistrationStatus::kNotEnoughPoints);
  const std::vector<Vec3f> empty;
  EXPECT_EQ(kabsch_fit(empty, empty, {}, est), RegistrationStatus::kNotEnoughPoints);
  const std::vector<Vec3f> line = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}};
  EXPECT_EQ(kabsch_fit(line, line, {}, est), RegistrationStatus::kDegenerate);
  const std::vector<Vec3f> same(5, Vec3f(1, 2, 3));
  EXPECT_EQ(kabsch_fit(same, same, {}, est), RegistrationStatus::kDegenerate);
  const std::vector<Vec3f> three = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_EQ(kabsch_fit(three, two, {}, est), RegistrationStatus::kInvalidInput);
  // NaN pairs are skipped, not propagated.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<Vec3f> with_nan = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {nan, 0, 0}, {0, 0, 1}};
  std::uint32_t skipped = 0;
  EXPECT_EQ(kabsch_fit(with_nan, with_nan, {}, est, {}, &skipped), RegistrationStatus::kOk);
  EXPECT_EQ(skipped, 1u);
  EXPECT_TRUE(est.allFinite());
  EXPECT_LT(translation_error(est, Mat4d::Identity()), 1e-12);
  Mat4d untouched = Mat4d::Constant(7.0);
  EXPECT_EQ(kabsch_fit(line, line, {}, untouched), RegistrationStatus::kDegenerate);
  EXPECT_EQ(untouched, Mat4d::Constant(7.0));
}

}  // namespace
}  // namespace v2xloc
