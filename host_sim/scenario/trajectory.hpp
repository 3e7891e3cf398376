// Smooth vehicle trajectories: a planar path of straight lines, circular arcs and clothoids,
// driven with a smooth speed profile v(t) = v0 + dv sin(w t) (or standing still), on the ground of
// a Terrain (height, roll and pitch from the road under the wheels). A turn enters and leaves its
// arc on clothoids (the transition curves of road design; a driver steers the same way): a
// straight meeting an arc directly would step the yaw rate within one sample, which no car can.
// Everything is analytic (clothoid positions: quadrature to ~1e-12 m), so the ground truth at any
// time (frames, LiDAR firings, 100 Hz vehicle signals) is exact.
#pragma once

#include "host_sim/world/world.hpp"

#include <Eigen/Geometry>
#include <vector>

namespace v2xloc::sim {

class Path {
 public:
  explicit Path(const PlanarPose& start) : start_(start) {}
  Path& straight(double length);
  Path& arc(double radius, double angle);  // angle > 0: left turn (counter-clockwise)
  // Curvature changing linearly from its value at the path's end to `end_curvature` [1/m, signed]
  // over `length` [m] (a clothoid, the transition curve of road design).
  Path& clothoid(double length, double end_curvature);
  // A turn by `angle` on a circle of `radius`, entered and left on clothoids of `transition` [m]
  // each (they take transition / radius of the angle; the rest is the arc).
  Path& turn(double radius, double angle, double transition);

  double length() const { return total_; }
  // Pose at arc length s (clamped to [0, length]; beyond the end the path continues straight).
  PlanarPose at(double s) const;
  double curvature(double s) const;

 private:
  struct Segment {
    PlanarPose start;
    double length = 0;
    double curvature = 0, end_curvature = 0;  // 1/m, signed, at the start and the end
    double s0 = 0;
    PlanarPose along(double ds) const;  // 0 <= ds <= length
  };
  PlanarPose end_pose() const;
  Path& append(double length, double curvature, double end_curvature);  // a segment at the end
  double end_curvature() const { return segments_.empty() ? 0.0 : segments_.back().end_curvature; }
  PlanarPose start_;
  std::vector<Segment> segments_;
  double total_ = 0;
};

struct VehicleState {
  double t = 0;
  PlanarPose pose;
  double speed = 0;        // m/s, along the heading
  double yaw_rate = 0;     // rad/s
  double accel = 0;        // m/s^2, longitudinal (along the path)
  Terrain terrain;         // the ground the body stands on
  Eigen::Isometry3d body_to_enu() const { return terrain.vehicle_pose(pose.x, pose.y, pose.yaw); }
};

class Trajectory {
 public:
  Trajectory() : path_(PlanarPose{}) {}
  // s(t) = s0 + v0 t + (dv / w) (1 - cos(w t))  =>  v(t) = v0 + dv sin(w t).
  Trajectory(Path path, double s0, double v0, double dv = 0.0, double w = 0.0)
      : path_(std::move(path)), s0_(s0), v0_(v0), dv_(dv), w_(w) {}
  static Trajectory stationary(const PlanarPose& pose);

  VehicleState state(double t) const;
  PlanarPose pose(double t) const { return state(t).pose; }
  Eigen::Isometry3d body_to_enu(double t) const { return state(t).body_to_enu(); }
  bool is_stationary() const { return v0_ == 0.0 && dv_ == 0.0; }
  void set_terrain(const Terrain& terrain) { terrain_ = terrain; }

 private:
  Path path_;
  double s0_ = 0, v0_ = 0, dv_ = 0, w_ = 0;
  Terrain terrain_;
};

}  // namespace v2xloc::sim
