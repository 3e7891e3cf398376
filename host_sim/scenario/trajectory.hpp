// Smooth planar vehicle trajectories: a path of straight lines and circular arcs (continuous
// heading), driven with a smooth speed profile v(t) = v0 + dv sin(w t) (or standing still).
// Everything is analytic, so the ground truth at any time (frames, LiDAR firings, 100 Hz vehicle
// signals) is exact.
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

  double length() const { return total_; }
  // Pose at arc length s (clamped to [0, length]; beyond the end the path continues straight).
  PlanarPose at(double s) const;
  double curvature(double s) const;

 private:
  struct Segment {
    PlanarPose start;
    double length = 0, curvature = 0;  // 1/m, signed
    double s0 = 0;
  };
  PlanarPose end_pose() const;
  PlanarPose start_;
  std::vector<Segment> segments_;
  double total_ = 0;
};

struct VehicleState {
  double t = 0;
  PlanarPose pose;
  double speed = 0;        // m/s, along the heading
  double yaw_rate = 0;     // rad/s
  double accel = 0;        // m/s^2, longitudinal
  Eigen::Isometry3d body_to_enu() const;
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

 private:
  Path path_;
  double s0_ = 0, v0_ = 0, dv_ = 0, w_ = 0;
};

}  // namespace v2xloc::sim
