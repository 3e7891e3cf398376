#include "host_sim/scenario/trajectory.hpp"

#include <algorithm>
#include <cmath>

namespace v2xloc::sim {

namespace {

PlanarPose advance_straight(PlanarPose p, double ds) {
  p.x += ds * std::cos(p.yaw);
  p.y += ds * std::sin(p.yaw);
  return p;
}

}  // namespace

PlanarPose Path::Segment::along(double ds) const {
  PlanarPose p = start;
  const double k = curvature;
  if (end_curvature == k) {
    if (k == 0.0) return advance_straight(p, ds);
    const double a = ds * k;
    p.x += (std::sin(p.yaw + a) - std::sin(p.yaw)) / k;
    p.y += -(std::cos(p.yaw + a) - std::cos(p.yaw)) / k;
    p.yaw += a;
    return p;
  }
  // Clothoid: heading yaw0 + k u + c u^2 / 2; the position is the Fresnel-type integral of its
  // direction, by 4-point Gauss-Legendre over 16 equal parts (error far below 1e-12 m for the
  // transitions driven here, < 0.5 rad each).
  const double c = (end_curvature - k) / length;
  const auto heading = [&](double u) { return start.yaw + u * (k + 0.5 * c * u); };
  constexpr int kParts = 16;
  constexpr double kNode[2] = {0.3399810435848563, 0.8611363115940526};
  constexpr double kWeight[2] = {0.6521451548625461, 0.3478548451374538};
  const double h = ds / kParts;
  double dx = 0.0, dy = 0.0;
  for (int i = 0; i < kParts; ++i) {
    const double mid = (i + 0.5) * h;
    for (int j = 0; j < 2; ++j) {
      for (const double side : {-1.0, 1.0}) {
        const double a = heading(mid + side * kNode[j] * 0.5 * h);
        dx += kWeight[j] * std::cos(a);
        dy += kWeight[j] * std::sin(a);
      }
    }
  }
  p.x += 0.5 * h * dx;
  p.y += 0.5 * h * dy;
  p.yaw = heading(ds);
  return p;
}

PlanarPose Path::end_pose() const {
  if (segments_.empty()) return start_;
  return segments_.back().along(segments_.back().length);
}

Path& Path::append(double length, double curvature, double end_curvature) {
  Segment seg;
  seg.start = end_pose();
  seg.length = length;
  seg.curvature = curvature;
  seg.end_curvature = end_curvature;
  seg.s0 = total_;
  segments_.push_back(seg);
  total_ += length;
  return *this;
}

Path& Path::straight(double length) { return append(length, 0.0, 0.0); }

Path& Path::arc(double radius, double angle) {
  const double k = (angle >= 0 ? 1.0 : -1.0) / radius;
  return append(radius * std::abs(angle), k, k);
}

Path& Path::clothoid(double length, double end_curvature) {
  return append(length, this->end_curvature(), end_curvature);
}

Path& Path::turn(double radius, double angle, double transition) {
  const double sign = angle >= 0 ? 1.0 : -1.0;
  // Each clothoid turns by transition / (2 radius); two of them may take at most the whole angle.
  const double max_transition = radius * std::abs(angle);
  if (transition > max_transition) transition = max_transition;
  clothoid(transition, sign / radius);
  const double arc_angle = std::abs(angle) - transition / radius;
  if (arc_angle > 0.0) arc(radius, sign * arc_angle);
  return clothoid(transition, 0.0);
}

PlanarPose Path::at(double s) const {
  if (segments_.empty()) return advance_straight(start_, s);
  // Before the start the first segment's start heading extends backwards; past the end the path
  // continues straight along the final heading.
  std::size_t i = 0;
  while (i + 1 < segments_.size() && s >= segments_[i + 1].s0) ++i;
  const Segment& seg = segments_[i];
  const double ds = s - seg.s0;
  if (ds < 0.0) return advance_straight(seg.start, ds);
  if (ds > seg.length) return advance_straight(seg.along(seg.length), ds - seg.length);
  return seg.along(ds);
}

double Path::curvature(double s) const {
  for (std::size_t i = segments_.size(); i-- > 0;) {
    const Segment& seg = segments_[i];
    if (s < seg.s0) continue;
    const double ds = s - seg.s0;
    if (ds > seg.length) return 0.0;
    return seg.curvature + (seg.end_curvature - seg.curvature) * (ds / seg.length);
  }
  return 0.0;
}

Trajectory Trajectory::stationary(const PlanarPose& pose) {
  Path p(pose);
  return Trajectory(std::move(p), 0.0, 0.0);
}

VehicleState Trajectory::state(double t) const {
  VehicleState st;
  st.t = t;
  st.terrain = terrain_;
  double s = s0_ + v0_ * t;
  st.speed = v0_;
  st.accel = 0.0;
  if (dv_ != 0.0 && w_ != 0.0) {
    s += dv_ / w_ * (1.0 - std::cos(w_ * t));
    st.speed += dv_ * std::sin(w_ * t);
    st.accel = dv_ * w_ * std::cos(w_ * t);
  }
  st.pose = path_.at(s);
  st.yaw_rate = st.speed * path_.curvature(s);
  return st;
}

}  // namespace v2xloc::sim
