#include "host_sim/world/bvh.hpp"

#include <algorithm>
#include <limits>

namespace v2xloc::sim {
namespace {

constexpr std::uint32_t kLeafSize = 4;

double sq(double v) { return v * v; }

}  // namespace

// ---- primitive tests -------------------------------------------------------------------------

double material_reflectivity(int material) {
  switch (material) {
    case kMatGround: return 0.25;
    case kMatRoad: return 0.12;
    case kMatSidewalk: return 0.30;
    case kMatBuilding: return 0.45;
    case kMatFacadeDetail: return 0.55;
    case kMatPole: return 0.60;
    case kMatTrafficLight: return 0.35;
    case kMatTrunk: return 0.30;
    case kMatFoliage: return 0.20;
    case kMatParkedCar: return 0.70;
    case kMatVehicle: return 0.80;
    default: return 0.3;
  }
}

const char* material_name(int material) {
  static const char* kNames[kMatCount] = {"ground", "road", "sidewalk", "building", "facade_detail", "pole",
                                          "traffic_light", "trunk", "foliage", "parked_car", "vehicle"};
  return (material >= 0 && material < kMatCount) ? kNames[material] : "unknown";
}

bool intersect_aabb(const Ray& ray, const Aabb& box, double t_max, double& t_entry, int* entry_axis) {
  double t0 = 0.0, t1 = t_max;
  int axis = -1;
  for (int a = 0; a < 3; ++a) {
    double ta = (box.lo[a] - ray.origin[a]) * ray.inv_dir[a];
    double tb = (box.hi[a] - ray.origin[a]) * ray.inv_dir[a];
    if (ta > tb) std::swap(ta, tb);
    if (ta != ta) ta = -std::numeric_limits<double>::infinity();  // 0 * inf on a slab boundary
    if (tb != tb) tb = std::numeric_limits<double>::infinity();
    if (ta > t0) { t0 = ta; axis = a; }
    if (tb < t1) t1 = tb;
    if (t0 > t1) return false;
  }
  t_entry = t0;
  if (entry_axis) *entry_axis = axis;
  return true;
}

Primitive Primitive::box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int material, int object_id) {
  Primitive p;
  p.kind = Kind::kBox;
  p.lo = lo.cwiseMin(hi);
  p.hi = lo.cwiseMax(hi);
  p.material = material;
  p.object_id = object_id;
  return p;
}

Primitive Primitive::yaw_box(const Eigen::Vector3d& centre, const Eigen::Vector3d& half, double yaw, int material,
                             int object_id) {
  Primitive p;
  p.kind = Kind::kYawBox;
  p.centre = centre;
  p.half = half;
  p.yaw = yaw;
  p.cos_yaw = std::cos(yaw);
  p.sin_yaw = std::sin(yaw);
  p.material = material;
  p.object_id = object_id;
  return p;
}

Primitive Primitive::cylinder(double x, double y, double z0, double z1, double radius, int material, int object_id) {
  Primitive p;
  p.kind = Kind::kCylinder;
  p.centre = {x, y, 0.5 * (z0 + z1)};
  p.lo = {x - radius, y - radius, z0};
  p.hi = {x + radius, y + radius, z1};
  p.radius = radius;
  p.material = material;
  p.object_id = object_id;
  return p;
}

Primitive Primitive::sphere(const Eigen::Vector3d& centre, double radius, int material, int object_id) {
  Primitive p;
  p.kind = Kind::kSphere;
  p.centre = centre;
  p.radius = radius;
  p.lo = centre.array() - radius;
  p.hi = centre.array() + radius;
  p.material = material;
  p.object_id = object_id;
  return p;
}

Aabb Primitive::bounds() const {
  Aabb b;
  if (kind == Kind::kYawBox) {
    const double ex = std::abs(cos_yaw) * half.x() + std::abs(sin_yaw) * half.y();
    const double ey = std::abs(sin_yaw) * half.x() + std::abs(cos_yaw) * half.y();
    b.lo = centre - Eigen::Vector3d(ex, ey, half.z());
    b.hi = centre + Eigen::Vector3d(ex, ey, half.z());
  } else {
    b.lo = lo;
    b.hi = hi;
  }
  return b;
}

bool Primitive::intersect(const Ray& ray, double t_max, double& t, Eigen::Vector3d& normal) const {
  constexpr double kEps = 1e-9;
  switch (kind) {
    case Kind::kBox: {
      Aabb b{lo, hi};
      int axis = -1;
      double te = 0.0;
      if (!intersect_aabb(ray, b, t_max, te, &axis) || axis < 0 || te <= kEps) return false;
      t = te;
      normal = Eigen::Vector3d::Zero();
      normal[axis] = ray.dir[axis] > 0 ? -1.0 : 1.0;
      return true;
    }
    case Kind::kYawBox: {
      // Into the box frame: rotate by -yaw about z around the centre.
      const Eigen::Vector3d d0 = ray.origin - centre;
      const Eigen::Vector3d o(cos_yaw * d0.x() + sin_yaw * d0.y(), -sin_yaw * d0.x() + cos_yaw * d0.y(), d0.z());
      const Eigen::Vector3d d(cos_yaw * ray.dir.x() + sin_yaw * ray.dir.y(),
                              -sin_yaw * ray.dir.x() + cos_yaw * ray.dir.y(), ray.dir.z());
      Ray local(o, d);
      Aabb b{-half, half};
      int axis = -1;
      double te = 0.0;
      if (!intersect_aabb(local, b, t_max, te, &axis) || axis < 0 || te <= kEps) return false;
      t = te;
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      n[axis] = d[axis] > 0 ? -1.0 : 1.0;
      normal = {cos_yaw * n.x() - sin_yaw * n.y(), sin_yaw * n.x() + cos_yaw * n.y(), n.z()};
      return true;
    }
    case Kind::kCylinder: {
      const double ox = ray.origin.x() - centre.x(), oy = ray.origin.y() - centre.y();
      const double dx = ray.dir.x(), dy = ray.dir.y();
      double best = t_max;
      bool found = false;
      const double a = dx * dx + dy * dy;
      if (a > 1e-14) {
        const double b = ox * dx + oy * dy;
        const double c = ox * ox + oy * oy - radius * radius;
        const double disc = b * b - a * c;
        if (c > 0.0 && disc >= 0.0) {  // origin outside the infinite cylinder
          const double tc = (-b - std::sqrt(disc)) / a;
          const double z = ray.origin.z() + tc * ray.dir.z();
          if (tc > kEps && tc < best && z >= lo.z() && z <= hi.z()) {
            best = tc;
            normal = Eigen::Vector3d(ox + tc * dx, oy + tc * dy, 0.0) / radius;
            found = true;
          }
        }
      }
      // End caps.
      if (std::abs(ray.dir.z()) > 1e-12) {
        for (double zc : {lo.z(), hi.z()}) {
          const bool from_outside = (zc == hi.z()) ? ray.origin.z() > zc : ray.origin.z() < zc;
          if (!from_outside) continue;
          const double tc = (zc - ray.origin.z()) / ray.dir.z();
          if (tc <= kEps || tc >= best) continue;
          if (sq(ox + tc * dx) + sq(oy + tc * dy) <= radius * radius) {
            best = tc;
            normal = Eigen::Vector3d(0, 0, zc == hi.z() ? 1.0 : -1.0);
            found = true;
          }
        }
      }
      if (found) t = best;
      return found;
    }
    case Kind::kSphere: {
      const Eigen::Vector3d oc = ray.origin - centre;
      const double b = oc.dot(ray.dir);
      const double c = oc.squaredNorm() - radius * radius;
      if (c <= 0.0) return false;
      const double disc = b * b - c;
      if (disc < 0.0) return false;
      const double tc = -b - std::sqrt(disc);
      if (tc <= kEps || tc >= t_max) return false;
      t = tc;
      normal = (oc + tc * ray.dir) / radius;
      return true;
    }
  }
  return false;
}

// ---- BVH --------------------------------------------------------------------------------------

void Bvh::build(const std::vector<Primitive>& prims) {
  nodes_.clear();
  order_.resize(prims.size());
  std::vector<Aabb> boxes(prims.size());
  for (std::uint32_t i = 0; i < prims.size(); ++i) {
    order_[i] = i;
    boxes[i] = prims[i].bounds();
  }
  nodes_.reserve(2 * prims.size() + 1);
  if (!prims.empty()) build_node(boxes, 0, static_cast<std::uint32_t>(prims.size()));
}

std::uint32_t Bvh::build_node(const std::vector<Aabb>& boxes, std::uint32_t begin, std::uint32_t end) {
  const auto index = static_cast<std::uint32_t>(nodes_.size());
  nodes_.push_back({});
  Aabb box, centres;
  for (std::uint32_t i = begin; i < end; ++i) {
    box.expand(boxes[order_[i]]);
    centres.expand(boxes[order_[i]].centre());
  }
  nodes_[index].box = box;
  if (end - begin <= kLeafSize) {
    nodes_[index].first = begin;
    nodes_[index].count = end - begin;
    return index;
  }
  const Eigen::Vector3d ext = centres.hi - centres.lo;
  int axis = 0;
  if (ext.y() > ext[axis]) axis = 1;
  if (ext.z() > ext[axis]) axis = 2;
  const std::uint32_t mid = begin + (end - begin) / 2;
  // Deterministic median split (ties broken by index).
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](std::uint32_t a, std::uint32_t b) {
                     const double ca = boxes[a].centre()[axis], cb = boxes[b].centre()[axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  build_node(boxes, begin, mid);  // left child is index + 1
  const std::uint32_t right = build_node(boxes, mid, end);
  nodes_[index].first = right;
  nodes_[index].count = 0;
  return index;
}

int Bvh::closest(const std::vector<Primitive>& prims, const Ray& ray, double t_max, double& t,
                 Eigen::Vector3d& normal) const {
  if (nodes_.empty()) return -1;
  int best = -1;
  double best_t = t_max;
  std::uint32_t stack[128];
  int sp = 0;
  double t_entry = 0.0;
  if (!intersect_aabb(ray, nodes_[0].box, best_t, t_entry)) return -1;
  stack[sp++] = 0;
  while (sp > 0) {
    const Node& node = nodes_[stack[--sp]];
    if (node.count > 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
        double tc = 0.0;
        Eigen::Vector3d n;
        if (prims[order_[i]].intersect(ray, best_t, tc, n) && tc < best_t) {
          best_t = tc;
          best = static_cast<int>(order_[i]);
          normal = n;
        }
      }
      continue;
    }
    const std::uint32_t left = static_cast<std::uint32_t>(&node - nodes_.data()) + 1, right = node.first;
    double tl = 0.0, tr = 0.0;
    const bool hl = intersect_aabb(ray, nodes_[left].box, best_t, tl);
    const bool hr = intersect_aabb(ray, nodes_[right].box, best_t, tr);
    if (hl && hr) {  // push the far child first so the near one is visited first
      if (tl <= tr) { stack[sp++] = right; stack[sp++] = left; }
      else { stack[sp++] = left; stack[sp++] = right; }
    } else if (hl) {
      stack[sp++] = left;
    } else if (hr) {
      stack[sp++] = right;
    }
  }
  if (best >= 0) t = best_t;
  return best;
}

}  // namespace v2xloc::sim
