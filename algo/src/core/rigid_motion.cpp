#include "v2xloc/algo/core/rigid_motion.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc {

Mat3d skew(const Vec3d& v) {
  Mat3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

namespace {
// Coefficients of exp/log as functions of theta, with Taylor series below 1e-4 rad where the
// closed forms lose precision: a = sin t / t, b = (1 - cos t) / t^2, c = (t - sin t) / t^3.
struct ExpCoefficients {
  double a, b, c;
};
ExpCoefficients exp_coefficients(double theta) {
  const double t2 = theta * theta;
  if (theta < 1e-4) {
    return {1.0 - t2 / 6.0, 0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0};
  }
  const double s = det::sin(theta), c = det::cos(theta);
  return {s / theta, (1.0 - c) / t2, (theta - s) / (t2 * theta)};
}
}  // namespace

Mat3d so3_exp(const Vec3d& w) {
  const double theta = std::sqrt(w.squaredNorm());
  const ExpCoefficients k = exp_coefficients(theta);
  const Mat3d W = skew(w);
  return Mat3d::Identity() + k.a * W + k.b * (W * W);
}

Mat3d so3_exp_closed_form(const Vec3d& w) {
  const double theta2 = w.squaredNorm();
  const Mat3d k = skew(w);
  if (theta2 < 1e-20) return Mat3d::Identity() + k;
  const double theta = std::sqrt(theta2);
  const double a = det::sin(theta) / theta;
  const double b = (1.0 - det::cos(theta)) / theta2;
  return Mat3d::Identity() + a * k + b * (k * k);
}

Vec3d so3_log(const Mat3d& R) {
  double cos_theta = 0.5 * (R.trace() - 1.0);
  if (cos_theta > 1.0) cos_theta = 1.0;
  if (cos_theta < -1.0) cos_theta = -1.0;
  const Vec3d vee(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));  // 2 sin(t) axis
  const double sin_theta = 0.5 * std::sqrt(vee.squaredNorm());
  const double theta = det::atan2(sin_theta, cos_theta);
  if (theta < 1e-4) return 0.5 * (1.0 + theta * theta / 6.0) * vee;
  if (theta < det::kPi - 1e-4) return (theta / (2.0 * sin_theta)) * vee;
  // Near pi: axis from the diagonal of (R + I) / 2 = a a^T (largest column), sign from vee.
  const Mat3d B = 0.5 * (R + Mat3d::Identity());
  int k = 0;
  if (B(1, 1) > B(k, k)) k = 1;
  if (B(2, 2) > B(k, k)) k = 2;
  Vec3d axis = B.col(k) / std::sqrt(B(k, k));
  axis /= std::sqrt(axis.squaredNorm());
  if (axis.dot(vee) < 0.0) axis = -axis;
  return theta * axis;
}

Mat4d se3_exp(const Vec6d& xi) {
  const Vec3d rho = xi.head<3>(), w = xi.tail<3>();
  const double theta = std::sqrt(w.squaredNorm());
  const ExpCoefficients k = exp_coefficients(theta);
  const Mat3d W = skew(w), W2 = W * W;
  const Mat3d V = Mat3d::Identity() + k.b * W + k.c * W2;  // left Jacobian of SO(3)
  Mat4d T = Mat4d::Identity();
  T.topLeftCorner<3, 3>() = Mat3d::Identity() + k.a * W + k.b * W2;
  T.topRightCorner<3, 1>() = V * rho;
  return T;
}

Vec6d se3_log(const Mat4d& T) {
  const Mat3d R = T.topLeftCorner<3, 3>();
  const Vec3d w = so3_log(R);
  const double theta = std::sqrt(w.squaredNorm());
  const Mat3d W = skew(w), W2 = W * W;
  // V^-1 = I - W/2 + (1/t^2) (1 - a / (2 b)) W^2   (a, b as in exp_coefficients)
  double d;
  if (theta < 1e-4) {
    d = 1.0 / 12.0 + theta * theta / 720.0;
  } else {
    const ExpCoefficients k = exp_coefficients(theta);
    d = (1.0 - k.a / (2.0 * k.b)) / (theta * theta);
  }
  const Mat3d V_inv = Mat3d::Identity() - 0.5 * W + d * W2;
  Vec6d xi;
  xi.head<3>() = V_inv * Vec3d(T.topRightCorner<3, 1>());
  xi.tail<3>() = w;
  return xi;
}

Mat4d se3_inverse(const Mat4d& T) {
  Mat4d inv = Mat4d::Identity();
  const Mat3d Rt = T.topLeftCorner<3, 3>().transpose();
  inv.topLeftCorner<3, 3>() = Rt;
  inv.topRightCorner<3, 1>() = -(Rt * Vec3d(T.topRightCorner<3, 1>()));
  return inv;
}

double yaw_of(const Mat3d& R) { return det::atan2(R(1, 0), R(0, 0)); }

Mat3d rot_z(double yaw) {
  const double c = det::cos(yaw), s = det::sin(yaw);
  Mat3d R;
  R << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;
  return R;
}

Mat3d orthonormalize(const Mat3d& R) {
  Vec3d x = R.col(0);
  x /= std::sqrt(x.squaredNorm());
  Vec3d y = R.col(1) - x.dot(R.col(1)) * x;
  y /= std::sqrt(y.squaredNorm());
  Mat3d out;
  out.col(0) = x;
  out.col(1) = y;
  out.col(2) = x.cross(y);
  return out;
}

}  // namespace v2xloc
