#include "host_sim/world/intersection_world.hpp"

#include "host_sim/common/rng.hpp"

#include <algorithm>
#include <cmath>

namespace v2xloc::sim {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
using L = IntersectionLayout;

constexpr double kSidewalkOuter = L::kRoadHalfWidth + L::kSidewalkWidth;  // 11 m

// Facade detail on one street-facing face of a box building: floor ledges, pilasters between
// window bays and random balconies. `axis` is the face normal axis (0: x, 1: y), `sign` its
// direction, `plane` the face coordinate, [a0, a1] the face extent along the other horizontal axis.
void add_facade(World& w, Rng& rng, int axis, double sign, double plane, double a0, double a1, double height,
                int object_id) {
  const int other = 1 - axis;
  auto make_box = [&](double along0, double along1, double out0, double out1, double z0, double z1) {
    Vector3d lo, hi;
    lo[other] = along0;
    hi[other] = along1;
    lo[axis] = plane + sign * out0;
    hi[axis] = plane + sign * out1;
    lo.z() = z0;
    hi.z() = z1;
    w.add(Primitive::box(lo, hi, kMatFacadeDetail, object_id));
  };
  const double floor_h = rng.uniform(3.0, 3.6);
  // Ground-floor shop fronts are recessed: a plinth band and floor ledges protrude instead.
  make_box(a0, a1, 0.0, 0.12, 0.0, 0.6);
  for (double z = floor_h; z < height - 1.0; z += floor_h) make_box(a0, a1, 0.0, 0.25, z - 0.2, z + 0.05);
  // Cornice at the roof line.
  make_box(a0, a1, 0.0, 0.45, height - 0.5, height);
  // Pilasters: vertical strips between window bays give the facade depth every few metres.
  const double bay = rng.uniform(3.2, 4.8);
  for (double s = a0 + bay; s < a1 - 0.5; s += bay) make_box(s - 0.25, s + 0.25, 0.0, 0.3, floor_h, height - 0.5);
  // Balconies on some bays and floors.
  const double p_balcony = rng.uniform(0.0, 0.35);
  for (double s = a0 + 0.5 * bay; s < a1 - bay * 0.5; s += bay) {
    for (double z = 2.0 * floor_h; z < height - floor_h; z += floor_h) {
      if (!rng.bernoulli(p_balcony)) continue;
      const double half_w = std::min(0.5 * bay - 0.4, 1.4);
      make_box(s - half_w, s + half_w, 0.0, 1.2, z - 0.05, z + 0.1);       // slab
      make_box(s - half_w, s + half_w, 1.1, 1.2, z + 0.1, z + 1.0);        // parapet
    }
  }
}

// One box building: footprint [lo, hi], street faces get detail. `street_faces`: bit 0 +x,
// bit 1 -x, bit 2 +y, bit 3 -y.
void add_building(IntersectionWorld& iw, Rng& rng, const WorldConfig& cfg, Vector2d lo, Vector2d hi, double height,
                  unsigned street_faces) {
  World& w = iw.world;
  const int id = w.new_object_id();
  w.add(Primitive::box(Vector3d(lo.x(), lo.y(), 0.0), Vector3d(hi.x(), hi.y(), height), kMatBuilding, id));
  iw.buildings.push_back({lo, hi, height});
  if (cfg.facade_detail) {
    if (street_faces & 1u) add_facade(w, rng, 0, +1.0, hi.x(), lo.y(), hi.y(), height, id);
    if (street_faces & 2u) add_facade(w, rng, 0, -1.0, lo.x(), lo.y(), hi.y(), height, id);
    if (street_faces & 4u) add_facade(w, rng, 1, +1.0, hi.y(), lo.x(), hi.x(), height, id);
    if (street_faces & 8u) add_facade(w, rng, 1, -1.0, lo.y(), lo.x(), hi.x(), height, id);
  }
  // Rooftop structure (stair house / HVAC) on larger roofs.
  if ((hi - lo).minCoeff() > 10.0 && rng.bernoulli(0.6)) {
    // One draw per statement: argument evaluation order is unspecified (differs across ISAs).
    const double cx = rng.uniform(-2, 2);
    const double cy = rng.uniform(-2, 2);
    const double hx = rng.uniform(1.5, 3.5);
    const double hy = rng.uniform(1.5, 3.5);
    const Vector2d c = 0.5 * (lo + hi) + Vector2d(cx, cy);
    const Vector2d h(hx, hy);
    w.add(Primitive::box(Vector3d(c.x() - h.x(), c.y() - h.y(), height),
                         Vector3d(c.x() + h.x(), c.y() + h.y(), height + rng.uniform(2.0, 3.5)), kMatBuilding, id));
  }
}

// Buildings of one corner quadrant (sx, sy = +-1): a row along the E-W road and a row along the
// N-S road, with varied widths, depths, set-backs, gaps and heights; the corner lot is L-shaped
// sometimes.
void add_quadrant(IntersectionWorld& iw, Rng& rng, const WorldConfig& cfg, double sx, double sy) {
  const unsigned face_towards_ns_road = sx > 0 ? 2u : 1u;   // facade facing x = 0
  const unsigned face_towards_ew_road = sy > 0 ? 8u : 4u;   // facade facing y = 0
  auto quad_box = [&](double u0, double u1, double v0, double v1, double h, unsigned faces) {
    // u along x (distance from the N-S axis), v along y; mirror into the quadrant.
    const Vector2d a(sx * u0, sy * v0), b(sx * u1, sy * v1);
    add_building(iw, rng, cfg, a.cwiseMin(b), a.cwiseMax(b), h, faces);
  };
  // Corner building.
  const double set_u = kSidewalkOuter + rng.uniform(0.0, 3.0);
  const double set_v = kSidewalkOuter + rng.uniform(0.0, 3.0);
  const double corner_u = set_u + rng.uniform(16.0, 26.0);
  const double corner_v = set_v + rng.uniform(16.0, 26.0);
  const double corner_h = rng.uniform(22.0, 40.0);
  if (rng.bernoulli(0.5)) {  // L-shape: two wings with different heights
    const double wing = rng.uniform(9.0, 13.0);
    quad_box(set_u, corner_u, set_v, set_v + wing, corner_h, face_towards_ew_road | face_towards_ns_road);
    quad_box(set_u, set_u + wing, set_v + wing, corner_v, corner_h * rng.uniform(0.6, 0.9), face_towards_ns_road);
  } else {
    quad_box(set_u, corner_u, set_v, corner_v, corner_h, face_towards_ew_road | face_towards_ns_road);
  }
  // Row along the E-W road (increasing u).
  double u = corner_u + rng.uniform(0.0, 4.0);
  while (u < L::kExtent - 8.0) {
    const double width = rng.uniform(12.0, 28.0);
    const double back = kSidewalkOuter + rng.uniform(0.0, 5.0);
    const double depth = rng.uniform(12.0, 22.0);
    quad_box(u, std::min(u + width, L::kExtent), back, back + depth, rng.uniform(10.0, 38.0), face_towards_ew_road);
    u += width + (rng.bernoulli(0.4) ? rng.uniform(2.0, 6.0) : 0.0);
  }
  // Row along the N-S road (increasing v).
  double v = corner_v + rng.uniform(0.0, 4.0);
  while (v < L::kExtent - 8.0) {
    const double width = rng.uniform(12.0, 28.0);
    const double back = kSidewalkOuter + rng.uniform(0.0, 5.0);
    const double depth = rng.uniform(12.0, 22.0);
    quad_box(back, back + depth, v, std::min(v + width, L::kExtent), rng.uniform(10.0, 38.0), face_towards_ns_road);
    v += width + (rng.bernoulli(0.4) ? rng.uniform(2.0, 6.0) : 0.0);
  }
}

void add_sidewalks(World& w) {
  const double r = L::kRoadHalfWidth, o = kSidewalkOuter, e = L::kExtent, h = L::kCurbHeight;
  // Four L-shaped corner sidewalks as two boxes each: along the E-W road and along the N-S road.
  for (double sx : {-1.0, 1.0}) {
    for (double sy : {-1.0, 1.0}) {
      const int id = w.new_object_id();
      const Vector3d a1(sx * r, sy * r, 0.0), b1(sx * e, sy * o, h);
      w.add(Primitive::box(a1.cwiseMin(b1), a1.cwiseMax(b1), kMatSidewalk, id));
      const Vector3d a2(sx * r, sy * o, 0.0), b2(sx * o, sy * e, h);
      w.add(Primitive::box(a2.cwiseMin(b2), a2.cwiseMax(b2), kMatSidewalk, id));
    }
  }
}

void add_lamp(IntersectionWorld& iw, double x, double y, double arm_dx, double arm_dy) {
  World& w = iw.world;
  const int id = w.new_object_id();
  w.add(Primitive::cylinder(x, y, 0.0, 8.0, 0.12, kMatPole, id));
  const Vector3d a(x, y, 7.85), b(x + arm_dx, y + arm_dy, 8.0);
  w.add(Primitive::box(a.cwiseMin(b) - Vector3d(0.06, 0.06, 0), a.cwiseMax(b) + Vector3d(0.06, 0.06, 0), kMatPole, id));
}

void add_traffic_light(IntersectionWorld& iw, double x, double y, double arm_dx, double arm_dy) {
  World& w = iw.world;
  const int id = w.new_object_id();
  w.add(Primitive::cylinder(x, y, 0.0, 6.0, 0.15, kMatPole, id));
  const Vector3d a(x, y, 5.6), b(x + arm_dx, y + arm_dy, 5.8);
  w.add(Primitive::box(a.cwiseMin(b) - Vector3d(0.08, 0.08, 0), a.cwiseMax(b) + Vector3d(0.08, 0.08, 0), kMatPole, id));
  // Signal heads hanging from the arm and one on the pole.
  for (double f : {0.55, 0.9}) {
    const Vector3d c(x + f * arm_dx, y + f * arm_dy, 5.0);
    w.add(Primitive::box(c - Vector3d(0.2, 0.2, 0.55), c + Vector3d(0.2, 0.2, 0.55), kMatTrafficLight, id));
  }
  w.add(Primitive::box(Vector3d(x - 0.2, y - 0.2, 2.2), Vector3d(x + 0.2, y + 0.2, 3.2), kMatTrafficLight, id));
}

void add_tree(IntersectionWorld& iw, Rng& rng, double x, double y) {
  World& w = iw.world;
  const int id = w.new_object_id();
  const double trunk_h = rng.uniform(2.5, 3.5), crown_r = rng.uniform(1.6, 2.6);
  w.add(Primitive::cylinder(x, y, 0.0, trunk_h + 0.5, rng.uniform(0.15, 0.25), kMatTrunk, id));
  const Vector3d c(x, y, trunk_h + crown_r * 0.8);
  w.add(Primitive::sphere(c, crown_r, kMatFoliage, id));
}

void add_parked_car(IntersectionWorld& iw, double x, double y, double yaw) {
  World& w = iw.world;
  const int id = w.new_object_id();
  const double c = std::cos(yaw), s = std::sin(yaw);
  w.add(Primitive::yaw_box(Vector3d(x, y, 0.75), Vector3d(2.25, 0.9, 0.45), yaw, kMatParkedCar, id));
  w.add(Primitive::yaw_box(Vector3d(x - 0.2 * c, y - 0.2 * s, 1.43), Vector3d(1.2, 0.82, 0.23), yaw, kMatParkedCar, id));
}

}  // namespace

void build_intersection_world(const WorldConfig& cfg, IntersectionWorld& iw) {
  iw = IntersectionWorld{};
  Rng rng(derive_seed(cfg.seed, {0x574F524C44ull}));  // "WORLD"
  add_sidewalks(iw.world);
  if (cfg.buildings) {
    for (double sx : {1.0, -1.0})
      for (double sy : {1.0, -1.0}) add_quadrant(iw, rng, cfg, sx, sy);
  }
  // Masts of the infrastructure LiDARs at the four sidewalk corners (top 0.3 m below the sensor).
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0}) {
      const double c = L::kRoadHalfWidth + 2.5;
      iw.world.add(Primitive::cylinder(sx * c, sy * c, 0.0, 4.7, 0.12, kMatPole, iw.world.new_object_id()));
    }
  if (cfg.street_furniture) {
    const double curb = L::kRoadHalfWidth + 0.6;
    // Traffic lights at the four corners, arms reaching over the approaching lanes.
    add_traffic_light(iw, curb, -curb, 0.0, 5.5);     // SE corner, over northbound... (x arm)
    add_traffic_light(iw, -curb, curb, 0.0, -5.5);
    add_traffic_light(iw, curb + 0.01, curb, -5.5, 0.0);
    add_traffic_light(iw, -curb, -curb - 0.01, 5.5, 0.0);
    // Lamps and trees along all four arms, both sides.
    for (double side : {-1.0, 1.0}) {
      for (double d = 22.0; d < L::kExtent - 5.0; d += rng.uniform(24.0, 30.0)) {
        for (double dir : {-1.0, 1.0}) {
          add_lamp(iw, dir * d, side * curb, 0.0, -side * 1.5);   // along the E-W road
          add_lamp(iw, side * curb, dir * d + 3.0, -side * 1.5, 0.0);  // along the N-S road
        }
      }
      for (double d = 16.0 + rng.uniform(0, 4); d < L::kExtent - 5.0; d += rng.uniform(9.0, 16.0)) {
        for (double dir : {-1.0, 1.0}) {
          if (rng.bernoulli(0.75)) add_tree(iw, rng, dir * d, side * (L::kRoadHalfWidth + 2.2));
          if (rng.bernoulli(0.75)) add_tree(iw, rng, side * (L::kRoadHalfWidth + 2.2), dir * d);
        }
      }
    }
  }
  if (cfg.parked_cars) {
    // Parked cars in the outer lanes away from the crossing (the scenarios drive the inner lanes).
    for (int arm = 0; arm < 4; ++arm) {
      for (double side : {-1.0, 1.0}) {
        double d = 30.0 + rng.uniform(0.0, 8.0);
        while (d < L::kExtent - 5.0) {
          if (rng.bernoulli(0.6)) {
            const double lat = side * (L::kOuterLane + 0.6) + rng.uniform(-0.2, 0.2);
            const double yaw_jitter = rng.uniform(-0.04, 0.04);
            const double sign = (arm < 2) ? (arm == 0 ? 1.0 : -1.0) : (arm == 2 ? 1.0 : -1.0);
            if (arm < 2) add_parked_car(iw, sign * d, lat, yaw_jitter);
            else add_parked_car(iw, lat, sign * d, M_PI / 2 + yaw_jitter);
          }
          d += rng.uniform(5.5, 9.0);
        }
      }
    }
  }
  iw.world.drape_on(cfg.terrain);
  iw.world.build();
}

}  // namespace v2xloc::sim
