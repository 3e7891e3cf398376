#include "host_sim/world/terrain.hpp"

#include <algorithm>
#include <cmath>

namespace v2xloc::sim {
namespace {

constexpr double kHalfWheelbase = 1.4;  // [m] sedan (make_car_body: 4.6 m long)
constexpr double kHalfTrack = 0.8;      // [m]
constexpr double kHitTolerance = 1e-4;  // [m] above the ground when sphere tracing stops
constexpr int kMaxTraceSteps = 4096;

}  // namespace

double Terrain::height(double x, double y) const {
  const double along = x * std::cos(grade_heading) + y * std::sin(grade_heading);
  // Distance to the nearer road axis, capped at the curb: off the roads the ground stays at curb level.
  const double to_axis = std::min(std::min(std::abs(x), std::abs(y)), road_half_width);
  return grade * along - crown * to_axis;
}

Eigen::Vector3d Terrain::normal(double x, double y) const {
  Eigen::Vector2d gradient(grade * std::cos(grade_heading), grade * std::sin(grade_heading));
  const double ax = std::abs(x), ay = std::abs(y);
  if (std::min(ax, ay) < road_half_width) {
    if (ax < ay) gradient.x() -= crown * (x < 0.0 ? -1.0 : 1.0);
    else gradient.y() -= crown * (y < 0.0 ? -1.0 : 1.0);
  }
  return Eigen::Vector3d(-gradient.x(), -gradient.y(), 1.0).normalized();
}

bool Terrain::intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_max, double& t) const {
  if (flat()) {  // the plane z = 0, as the world always cast it
    if (dir.z() >= -1e-12 || origin.z() <= 0.0) return false;
    t = -origin.z() / dir.z();
    return t < t_max;
  }
  // Sphere tracing: the gap to the ground falls at most at rate `closing` per metre of ray, so a
  // step of gap / closing never passes through it.
  const double closing = max_slope() * std::hypot(dir.x(), dir.y()) - dir.z();
  double s = 0.0;
  double gap = origin.z() - height(origin.x(), origin.y());
  if (gap <= 0.0 || closing <= 0.0) return false;
  for (int k = 0; k < kMaxTraceSteps && s < t_max; ++k) {
    if (gap < kHitTolerance) {
      t = s;
      return true;
    }
    s += gap / closing;
    const Eigen::Vector3d p = origin + s * dir;
    gap = p.z() - height(p.x(), p.y());
  }
  return false;
}

Eigen::Isometry3d Terrain::vehicle_pose(double x, double y, double yaw) const {
  const Eigen::Vector2d fwd(std::cos(yaw), std::sin(yaw)), left(-fwd.y(), fwd.x());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  if (flat()) return T;
  const Eigen::Vector2d c(x, y);
  auto ground = [&](double a, double l) {
    const Eigen::Vector2d p = c + a * fwd + l * left;
    return height(p.x(), p.y());
  };
  const double fl = ground(kHalfWheelbase, kHalfTrack), fr = ground(kHalfWheelbase, -kHalfTrack);
  const double rl = ground(-kHalfWheelbase, kHalfTrack), rr = ground(-kHalfWheelbase, -kHalfTrack);
  const double pitch_rise = 0.5 * (fl + fr - rl - rr) / (2.0 * kHalfWheelbase);  // dz per metre forward
  const double roll_rise = 0.5 * (fl + rl - fr - rr) / (2.0 * kHalfTrack);       // dz per metre left
  const Eigen::Vector3d x_axis = Eigen::Vector3d(fwd.x(), fwd.y(), pitch_rise).normalized();
  const Eigen::Vector3d left_dir(left.x(), left.y(), roll_rise);
  const Eigen::Vector3d z_axis = x_axis.cross(left_dir).normalized();
  T.linear().col(0) = x_axis;
  T.linear().col(1) = z_axis.cross(x_axis);
  T.linear().col(2) = z_axis;
  T.translation().z() = 0.25 * (fl + fr + rl + rr);
  return T;
}

}  // namespace v2xloc::sim
