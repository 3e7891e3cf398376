// The GNSS course over ground (Doppler velocity): the only absolute heading the vehicle has
// before the map registration starts. It narrows the start-up search's yaw window and turns the
// pre-filter output. A course is taken only while driving forwards (reversing flips it).
#pragma once

#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc {

class GnssCourse {
 public:
  void configure(const GnssCourseParams& params);
  // Takes the fix's course when it is usable; true when it was (counted by the caller).
  bool update(const GnssInput& fix, const VehicleMotion& vehicle);
  // The course carried to time t [s] by the yaw rate; false when none is usable.
  bool at(double t, double yaw_rate, double& yaw) const;

 private:
  GnssCourseParams params_{};
  bool have_ = false;
  double yaw_ = 0.0;  // [rad] ENU yaw: 0 = east, counter-clockwise
  double t_ = 0.0;    // [s]
};

}  // namespace v2xloc
