#include "host_sim/scenario/trajectory.hpp"

#include <algorithm>
#include <cmath>

namespace v2xloc::sim {

PlanarPose Path::end_pose() const {
  if (segments_.empty()) return start_;
  const Segment& last = segments_.back();
  Path tmp = *this;
  return tmp.at(last.s0 + last.length);
}

Path& Path::straight(double length) {
  Segment seg;
  seg.start = end_pose();
  seg.length = length;
  seg.curvature = 0.0;
  seg.s0 = total_;
  segments_.push_back(seg);
  total_ += length;
  return *this;
}

Path& Path::arc(double radius, double angle) {
  Segment seg;
  seg.start = end_pose();
  seg.length = radius * std::abs(angle);
  seg.curvature = (angle >= 0 ? 1.0 : -1.0) / radius;
  seg.s0 = total_;
  segments_.push_back(seg);
  total_ += seg.length;
  return *this;
}

PlanarPose Path::at(double s) const {
  if (segments_.empty()) {
    PlanarPose p = start_;
    p.x += s * std::cos(p.yaw);
    p.y += s * std::sin(p.yaw);
    return p;
  }
  // Find the segment (before the start: extend the first straight backwards; after the end:
  // continue straight along the final heading).
  std::size_t i = 0;
  while (i + 1 < segments_.size() && s >= segments_[i + 1].s0) ++i;
  const Segment& seg = segments_[i];
  double ds = s - seg.s0;
  PlanarPose p = seg.start;
  double k = seg.curvature;
  if (ds < 0.0 || ds > seg.length) {
    if (ds > seg.length && k != 0.0) {  // past the end of a final arc: finish it, then straight
      const PlanarPose end = [&] {
        PlanarPose e = seg.start;
        const double a = seg.length * k;
        e.x += (std::sin(e.yaw + a) - std::sin(e.yaw)) / k;
        e.y += -(std::cos(e.yaw + a) - std::cos(e.yaw)) / k;
        e.yaw += a;
        return e;
      }();
      p = end;
      ds -= seg.length;
    }
    k = 0.0;
  }
  if (k == 0.0) {
    p.x += ds * std::cos(p.yaw);
    p.y += ds * std::sin(p.yaw);
  } else {
    const double a = ds * k;
    p.x += (std::sin(p.yaw + a) - std::sin(p.yaw)) / k;
    p.y += -(std::cos(p.yaw + a) - std::cos(p.yaw)) / k;
    p.yaw += a;
  }
  return p;
}

double Path::curvature(double s) const {
  for (std::size_t i = segments_.size(); i-- > 0;) {
    if (s >= segments_[i].s0) return (s <= segments_[i].s0 + segments_[i].length) ? segments_[i].curvature : 0.0;
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
