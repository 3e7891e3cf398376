#include "v2xloc/algo/localization/gnss_course.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc {

void GnssCourse::configure(const GnssCourseParams& params) {
  params_ = params;
  have_ = false;
  yaw_ = 0.0;
  t_ = 0.0;
}

bool GnssCourse::update(const GnssInput& in, const VehicleMotion& vehicle) {
  if (!params_.enabled || !in.velocity_valid || !std::isfinite(in.vel_east) ||
      !std::isfinite(in.vel_north) || !std::isfinite(in.speed_acc) || in.speed_acc < 0.0) {
    return false;
  }
  const double speed = std::sqrt(in.vel_east * in.vel_east + in.vel_north * in.vel_north);
  // Forward motion only (reversing flips the course); the wheel speed must agree it is moving.
  if (speed < params_.min_speed || !vehicle.valid || vehicle.speed < params_.min_speed) {
    return false;
  }
  if (det::atan2(in.speed_acc, speed) > params_.max_sigma) return false;
  have_ = true;
  yaw_ = det::atan2(in.vel_north, in.vel_east);
  t_ = in.t;
  return true;
}

bool GnssCourse::at(double t, double yaw_rate, double& yaw) const {
  if (!have_ || !(std::abs(t - t_) <= params_.max_age)) return false;
  yaw = det::wrap_pi(yaw_ + yaw_rate * (t - t_));
  return true;
}

}  // namespace v2xloc
