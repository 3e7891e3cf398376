// The simulated world: static analytic primitives in a BVH, an optional ground (the plane z = 0 or
// a sloped terrain), and moving vehicle bodies (yaw boxes) whose poses come from trajectories.
// Local ENU, metres.
#pragma once

#include "host_sim/world/bvh.hpp"
#include "host_sim/world/primitives.hpp"
#include "host_sim/world/ray_caster.hpp"
#include "host_sim/world/terrain.hpp"

#include <Eigen/Geometry>
#include <functional>
#include <string>
#include <vector>

namespace v2xloc::sim {

// Planar vehicle pose: x, y [m], yaw [rad]; height, roll and pitch follow the ground (Terrain).
struct PlanarPose {
  double x = 0.0, y = 0.0, yaw = 0.0;
};

// One moving body: a set of boxes in its body frame (x forward, y left, z up, origin on the ground
// at the footprint centre) plus a pose over time.
struct DynamicBody {
  std::string name;
  struct Part {
    Eigen::Vector3d centre;  // body frame
    Eigen::Vector3d half;
  };
  std::vector<Part> parts;
  std::function<PlanarPose(double t)> pose_at;
  int material = kMatVehicle;
  int object_id = -1;
};

// Dynamic bodies posed at one instant: the primitives a ray is tested against besides the BVH
// (level yaw boxes standing at the ground height under the body).
struct DynamicSnapshot {
  double t = 0.0;
  std::vector<Primitive> prims;   // yaw boxes in ENU
  std::vector<int> body_of_prim;  // which body each primitive belongs to
};

class World : public RayCaster {
 public:
  // Building up (call build() afterwards).
  int new_object_id() { return next_object_id_++; }
  void add(const Primitive& p) { prims_.push_back(p); }
  void build();
  void set_ground_plane(bool enabled) { ground_plane_ = enabled; }
  // Sloped ground (before build()): stands the static primitives on it (world_drape.cpp).
  void drape_on(const Terrain& terrain);
  int add_dynamic_body(DynamicBody body);  // returns its body index

  // Snapshot of all moving bodies at time t (cheap: a few boxes).
  DynamicSnapshot snapshot(double t) const;
  // Time used by the RayCaster interface (GNSS line-of-sight tests etc.).
  void set_time(double t) { current_ = snapshot(t); }

  // RayCaster: static world + bodies at the time given to set_time().
  bool cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range,
            RayHit& hit) const override;
  // Full query: bodies from `snap`, ignoring body `exclude_body` (the sensor's own vehicle).
  bool cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range, RayHit& hit,
            const DynamicSnapshot& snap, int exclude_body) const;

  const std::vector<Primitive>& primitives() const { return prims_; }
  const std::vector<DynamicBody>& bodies() const { return bodies_; }
  std::size_t bvh_nodes() const { return bvh_.node_count(); }
  bool ground_plane() const { return ground_plane_; }
  const Terrain& terrain() const { return terrain_; }

 private:
  std::vector<Primitive> prims_;
  std::vector<DynamicBody> bodies_;
  Bvh bvh_;
  DynamicSnapshot current_;
  bool ground_plane_ = true;
  Terrain terrain_;  // flat: the plane z = 0
  int next_object_id_ = 1;  // 0 is the ground plane
};

// Standard vehicle body (sedan-like, two boxes): 4.6 x 1.9 m, 1.5 m tall.
DynamicBody make_car_body(const std::string& name, std::function<PlanarPose(double)> pose_at);

}  // namespace v2xloc::sim
