// Analytic primitives the world is made of and their ray intersection tests. All tests return
// the entry distance along a unit direction; rays starting inside a solid do not hit it.
#pragma once

#include <Eigen/Core>

namespace v2xloc::sim {

// Surface classes (RayHit::material). Reflectivity per class drives LiDAR intensity.
enum Material : int {
  kMatGround = 0,
  kMatRoad = 1,
  kMatSidewalk = 2,
  kMatBuilding = 3,
  kMatFacadeDetail = 4,
  kMatPole = 5,
  kMatTrafficLight = 6,
  kMatTrunk = 7,
  kMatFoliage = 8,
  kMatParkedCar = 9,
  kMatVehicle = 10,
  kMatCount = 11,
};
double material_reflectivity(int material);
const char* material_name(int material);

struct Aabb {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300);
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-1e300);
  void expand(const Eigen::Vector3d& p) { lo = lo.cwiseMin(p); hi = hi.cwiseMax(p); }
  void expand(const Aabb& b) { lo = lo.cwiseMin(b.lo); hi = hi.cwiseMax(b.hi); }
  Eigen::Vector3d centre() const { return 0.5 * (lo + hi); }
};

struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d dir;      // unit
  Eigen::Vector3d inv_dir;  // 1/dir per axis (inf for 0)
  explicit Ray(const Eigen::Vector3d& o, const Eigen::Vector3d& d) : origin(o), dir(d), inv_dir(d.cwiseInverse()) {}
};

// Slab test (Kay & Kajiya 1986). Returns the entry distance in (t_min, t_max) or false.
bool intersect_aabb(const Ray& ray, const Aabb& box, double t_max, double& t_entry, int* entry_axis = nullptr);

struct Primitive {
  enum class Kind { kBox, kYawBox, kCylinder, kSphere };
  Kind kind = Kind::kBox;
  // kBox: lo/hi corners. kYawBox: centre, half extents, yaw (rotation about z).
  // kCylinder: vertical axis at centre.xy from z=lo.z to z=hi.z, radius. kSphere: centre, radius.
  Eigen::Vector3d lo = Eigen::Vector3d::Zero();
  Eigen::Vector3d hi = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half = Eigen::Vector3d::Zero();
  double yaw = 0.0, cos_yaw = 1.0, sin_yaw = 0.0;
  double radius = 0.0;
  int material = kMatGround;
  int object_id = -1;

  static Primitive box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int material, int object_id);
  static Primitive yaw_box(const Eigen::Vector3d& centre, const Eigen::Vector3d& half, double yaw, int material, int object_id);
  static Primitive cylinder(double x, double y, double z0, double z1, double radius, int material, int object_id);
  static Primitive sphere(const Eigen::Vector3d& centre, double radius, int material, int object_id);

  Aabb bounds() const;
  // Nearest entry in (1e-9, t_max); writes t and the outward unit normal.
  bool intersect(const Ray& ray, double t_max, double& t, Eigen::Vector3d& normal) const;
};

}  // namespace v2xloc::sim
