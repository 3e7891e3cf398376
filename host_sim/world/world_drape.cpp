// Standing the static world on a sloped ground (World::drape_on).
#include "host_sim/world/world.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace v2xloc::sim {
namespace {

constexpr double kSlabMaxHeight = 1.0;  // [m] ground-standing boxes this low follow the ground
constexpr double kSlabPiece = 1.0;      // [m] ... in pieces this long
constexpr double kFoundation = 0.3;     // [m] grounded parts reach this far below the ground

bool grounded(const Primitive& p) { return p.bounds().lo.z() <= 1e-9; }

double lowest_ground(const Terrain& terrain, const Aabb& box) {
  double low = terrain.height(box.lo.x(), box.lo.y());
  low = std::min(low, terrain.height(box.lo.x(), box.hi.y()));
  low = std::min(low, terrain.height(box.hi.x(), box.lo.y()));
  low = std::min(low, terrain.height(box.hi.x(), box.hi.y()));
  // The crown's ridge (a road's axis) can lie inside the footprint: the corners bound it from below.
  return low - kFoundation;
}

void add_slab_pieces(const Primitive& slab, const Terrain& terrain, std::vector<Primitive>& out) {
  const int nx = std::max(1, static_cast<int>(std::ceil((slab.hi.x() - slab.lo.x()) / kSlabPiece)));
  const int ny = std::max(1, static_cast<int>(std::ceil((slab.hi.y() - slab.lo.y()) / kSlabPiece)));
  const double dx = (slab.hi.x() - slab.lo.x()) / nx, dy = (slab.hi.y() - slab.lo.y()) / ny;
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) {
      Aabb piece;
      piece.lo = Eigen::Vector3d(slab.lo.x() + i * dx, slab.lo.y() + j * dy, 0.0);
      piece.hi = Eigen::Vector3d(i + 1 == nx ? slab.hi.x() : piece.lo.x() + dx,
                                 j + 1 == ny ? slab.hi.y() : piece.lo.y() + dy, 0.0);
      const Eigen::Vector3d c = piece.centre();
      piece.lo.z() = lowest_ground(terrain, piece);
      piece.hi.z() = slab.hi.z() + terrain.height(c.x(), c.y());
      out.push_back(Primitive::box(piece.lo, piece.hi, slab.material, slab.object_id));
    }
  }
}

// Raise a primitive by dz; a grounded one also reaches down to `floor`.
Primitive raised(Primitive p, double dz, bool to_floor, double floor) {
  switch (p.kind) {
    case Primitive::Kind::kYawBox: {
      double lo = p.centre.z() - p.half.z() + dz, hi = p.centre.z() + p.half.z() + dz;
      if (to_floor) lo = std::min(lo, floor);
      p.centre.z() = 0.5 * (lo + hi);
      p.half.z() = 0.5 * (hi - lo);
      return p;
    }
    case Primitive::Kind::kSphere:
      p.centre.z() += dz;
      p.lo.z() += dz;
      p.hi.z() += dz;
      return p;
    case Primitive::Kind::kBox:
    case Primitive::Kind::kCylinder:
      p.lo.z() += dz;
      p.hi.z() += dz;
      if (to_floor) p.lo.z() = std::min(p.lo.z(), floor);
      p.centre.z() = 0.5 * (p.lo.z() + p.hi.z());
      return p;
  }
  return p;
}

}  // namespace

// Each object rises by the ground height under its footprint's centre (buildings stay level, as on
// a real hillside); a part standing on the ground reaches into it, so no gap opens downhill; low
// slabs (sidewalks, plinths) are cut into pieces that follow the ground.
void World::drape_on(const Terrain& terrain) {
  terrain_ = terrain;
  if (terrain.flat()) return;
  std::map<int, Aabb> object_bounds;
  for (const Primitive& p : prims_) object_bounds[p.object_id].expand(p.bounds());
  std::vector<Primitive> draped;
  draped.reserve(prims_.size());
  for (const Primitive& p : prims_) {
    const bool on_ground = grounded(p);
    if (on_ground && p.kind == Primitive::Kind::kBox && p.hi.z() - p.lo.z() <= kSlabMaxHeight) {
      add_slab_pieces(p, terrain, draped);
      continue;
    }
    const Eigen::Vector3d c = object_bounds[p.object_id].centre();
    draped.push_back(raised(p, terrain.height(c.x(), c.y()), on_ground, lowest_ground(terrain, p.bounds())));
  }
  prims_ = std::move(draped);
}

}  // namespace v2xloc::sim
