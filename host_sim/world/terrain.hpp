// Ground height for drives on sloped streets: a site-wide grade (a city on a hillside) plus each
// road's crown (the cross slope that drains it, falling from the axis to the curbs). Flat by
// default, and a flat terrain casts exactly like the plane z = 0. Typical urban values: grades up
// to 5-8 %, crowns 1.5-2.5 % (AASHTO "Green Book", cross slopes of high-type pavements).
#pragma once

#include <Eigen/Geometry>

namespace v2xloc::sim {

struct Terrain {
  double grade = 0.0;            // [rise/run] site-wide slope
  double grade_heading = 0.0;    // [rad] ENU direction of steepest ascent (0: east)
  double crown = 0.0;            // [rise/run] road cross slope, axis down to the curb
  double road_half_width = 7.0;  // [m] the crown's extent from each road's axis

  bool flat() const { return grade == 0.0 && crown == 0.0; }
  double height(double x, double y) const;
  Eigen::Vector3d normal(double x, double y) const;  // unit, up
  // Largest |dh/ds| along any horizontal direction (the sphere-tracing step's Lipschitz bound).
  double max_slope() const { return grade + crown; }
  // First crossing of the ground along a unit ray in (0, t_max) from above it.
  bool intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_max, double& t) const;
  // A vehicle's pose on the ground: origin at the footprint centre on the ground, x along the
  // heading, attitude from the plane through its four wheel contacts.
  Eigen::Isometry3d vehicle_pose(double x, double y, double yaw) const;
};

}  // namespace v2xloc::sim
