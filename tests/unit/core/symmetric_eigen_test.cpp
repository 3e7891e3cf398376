// The closed-form smallest eigenvector against the Jacobi solver: random covariances of planes,
// lines, blobs and degenerate cases.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "v2xloc/algo/core/symmetric_eigen.hpp"

namespace v2xloc {
namespace {

Mat3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  q.normalize();
  return q.toRotationMatrix();
}

// R diag(l) R^T
Mat3d covariance(const Mat3d& R, double l0, double l1, double l2) {
  return R * Vec3d(l0, l1, l2).asDiagonal() * R.transpose();
}

double angle_between_axes(const Vec3d& a, const Vec3d& b) {
  const double c = std::min(1.0, std::abs(a.dot(b)) / (a.norm() * b.norm()));
  return std::acos(c);
}

TEST(SmallestEigenvector, MatchesJacobiOnSurfaces) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 5000; ++i) {
    const Mat3d R = random_rotation(rng);
    // a surface patch: two large spreads and a thin one (planarity 1e-6 .. 0.5)
    const double l2 = 0.01 + u(rng);
    const double l1 = l2 * (0.05 + 0.95 * u(rng));
    const double l0 = l1 * std::pow(10.0, -6.0 + 5.7 * u(rng));
    const Mat3d A = covariance(R, l0, l1, l2);
    const Vec3d v = smallest_eigenvector3(A);
    EXPECT_NEAR(v.norm(), 1.0, 1e-12);
    EXPECT_LT(angle_between_axes(v, R.col(0)), 1e-7) << "case " << i;
    Vec3d lambda;
    Mat3d vectors;
    symmetric_eigen3(A, lambda, vectors);
    EXPECT_LT(angle_between_axes(v, vectors.col(0)), 1e-7) << "case " << i;
  }
}

TEST(SmallestEigenvector, DegenerateCasesFallBackToJacobi) {
  std::mt19937 rng(11);
  // a line (two equal small eigenvalues), a sphere (all equal), zero
  const Mat3d R = random_rotation(rng);
  const Mat3d line = covariance(R, 1e-4, 1e-4, 1.0);
  Vec3d lambda;
  Mat3d vectors;
  symmetric_eigen3(line, lambda, vectors);
  EXPECT_EQ(smallest_eigenvector3(line), Vec3d(vectors.col(0)));
  const Mat3d sphere = 2.0 * Mat3d::Identity();
  EXPECT_NEAR(smallest_eigenvector3(sphere).norm(), 1.0, 1e-12);
  EXPECT_NEAR(smallest_eigenvector3(Mat3d::Zero()).norm(), 1.0, 1e-12);
}

TEST(SmallestEigenvector, ExactPlaneAndAxisAligned) {
  // a covariance of points on z = 0: the normal is +-z exactly
  Mat3d A;
  A << 2.0, 0.5, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 0.0;
  const Vec3d v = smallest_eigenvector3(A);
  EXPECT_NEAR(std::abs(v.z()), 1.0, 1e-12);
  // already diagonal, distinct
  const Mat3d D = Vec3d(3.0, 1.0, 2.0).asDiagonal();
  EXPECT_NEAR(std::abs(smallest_eigenvector3(D).y()), 1.0, 1e-12);
}

TEST(SmallestEigenvector, SameBitsEveryCall) {
  std::mt19937 rng(3);
  const Mat3d A = covariance(random_rotation(rng), 1e-3, 0.4, 0.9);
  const Vec3d a = smallest_eigenvector3(A);
  const Vec3d b = smallest_eigenvector3(A);
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace v2xloc
