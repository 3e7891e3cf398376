#include "host_sim/world/world.hpp"

#include <cmath>

namespace v2xloc::sim {

void World::build() { bvh_.build(prims_); }

int World::add_dynamic_body(DynamicBody body) {
  body.object_id = new_object_id();
  bodies_.push_back(std::move(body));
  current_ = snapshot(current_.t);
  return static_cast<int>(bodies_.size()) - 1;
}

DynamicSnapshot World::snapshot(double t) const {
  DynamicSnapshot s;
  s.t = t;
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    const auto& body = bodies_[b];
    const PlanarPose p = body.pose_at(t);
    const double c = std::cos(p.yaw), sn = std::sin(p.yaw);
    const double ground = terrain_.flat() ? 0.0 : terrain_.vehicle_pose(p.x, p.y, p.yaw).translation().z();
    for (const auto& part : body.parts) {
      const Eigen::Vector3d centre(p.x + c * part.centre.x() - sn * part.centre.y(),
                                   p.y + sn * part.centre.x() + c * part.centre.y(), part.centre.z() + ground);
      s.prims.push_back(Primitive::yaw_box(centre, part.half, p.yaw, body.material, body.object_id));
      s.body_of_prim.push_back(static_cast<int>(b));
    }
  }
  return s;
}

bool World::cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range, RayHit& hit) const {
  return cast(origin, dir, max_range, hit, current_, -1);
}

bool World::cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range, RayHit& hit,
                 const DynamicSnapshot& snap, int exclude_body) const {
  const Ray ray(origin, dir);
  double best = max_range;
  bool found = false;
  Eigen::Vector3d normal;
  double t = 0.0;
  const int idx = bvh_.closest(prims_, ray, best, t, normal);
  if (idx >= 0) {
    best = t;
    hit.normal = normal;
    hit.material = prims_[static_cast<std::size_t>(idx)].material;
    hit.object_id = prims_[static_cast<std::size_t>(idx)].object_id;
    found = true;
  }
  for (std::size_t i = 0; i < snap.prims.size(); ++i) {
    if (snap.body_of_prim[i] == exclude_body) continue;
    if (snap.prims[i].intersect(ray, best, t, normal) && t < best) {
      best = t;
      hit.normal = normal;
      hit.material = snap.prims[i].material;
      hit.object_id = snap.prims[i].object_id;
      found = true;
    }
  }
  double tg = 0.0;
  if (ground_plane_ && terrain_.intersect(origin, dir, best, tg)) {
    best = tg;
    const Eigen::Vector3d at = origin + tg * dir;
    hit.normal = terrain_.flat() ? Eigen::Vector3d::UnitZ() : terrain_.normal(at.x(), at.y());
    hit.material = kMatRoad;
    hit.object_id = 0;
    found = true;
  }
  if (found) hit.range = best;
  return found;
}

DynamicBody make_car_body(const std::string& name, std::function<PlanarPose(double)> pose_at) {
  DynamicBody b;
  b.name = name;
  b.parts.push_back({Eigen::Vector3d(0.0, 0.0, 0.3 + 0.45), Eigen::Vector3d(2.3, 0.95, 0.45)});    // body 0.3-1.2 m
  b.parts.push_back({Eigen::Vector3d(-0.2, 0.0, 1.2 + 0.25), Eigen::Vector3d(1.25, 0.85, 0.25)});  // cabin 1.2-1.7 m
  b.pose_at = std::move(pose_at);
  return b;
}

}  // namespace v2xloc::sim
