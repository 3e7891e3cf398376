// Test worlds for the GNSS model: an urban canyon of two rows of axis-aligned boxes along a
// north-south street, and open sky (a RayCaster that hits nothing).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "host_sim/world/ray_caster.hpp"

namespace v2xloc::test {

struct Box {
  Eigen::Vector3d lo, hi;
};

class BoxWorld : public sim::RayCaster {
 public:
  std::vector<Box> boxes;

  bool cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range,
            sim::RayHit& hit) const override {
    double best = max_range;
    bool found = false;
    for (std::size_t b = 0; b < boxes.size(); ++b) {
      // Slab test; remembers which slab the entry happened through for the normal.
      double t_near = -std::numeric_limits<double>::infinity(), t_far = std::numeric_limits<double>::infinity();
      int axis = -1;
      bool miss = false;
      for (int a = 0; a < 3; ++a) {
        if (std::abs(dir(a)) < 1e-15) {
          if (origin(a) < boxes[b].lo(a) || origin(a) > boxes[b].hi(a)) miss = true;
          continue;
        }
        double t0 = (boxes[b].lo(a) - origin(a)) / dir(a), t1 = (boxes[b].hi(a) - origin(a)) / dir(a);
        if (t0 > t1) std::swap(t0, t1);
        if (t0 > t_near) {
          t_near = t0;
          axis = a;
        }
        t_far = std::min(t_far, t1);
      }
      if (miss || axis < 0 || t_near > t_far || t_near <= 0.0 || t_near > best) continue;
      best = t_near;
      found = true;
      hit.range = t_near;
      hit.normal = Eigen::Vector3d::Zero();
      hit.normal(axis) = dir(axis) > 0.0 ? -1.0 : 1.0;
      hit.object_id = static_cast<int>(b);
      hit.material = 1;
    }
    return found;
  }
};

// A street along y from -250 to 250 m: street width `width` (facade to facade), blocks 18-45 m
// long with 3-6 m gaps, heights 10-40 m from a fixed pattern (no randomness: the world is a fixture).
inline BoxWorld make_canyon(double width = 24.0) {
  BoxWorld w;
  const double heights[] = {22, 35, 14, 40, 28, 18, 31, 12, 37, 25, 16, 33, 20, 38, 26, 11, 30, 24};
  const double lengths[] = {30, 22, 41, 18, 35, 27, 45, 20, 33, 25, 38, 19, 29, 42, 23, 36, 26, 31};
  const double gaps[] = {4, 3, 6, 5, 3, 4, 6, 3, 5, 4};
  for (int side = 0; side < 2; ++side) {
    double y = -250.0 + side * 11.0;
    int k = side * 5;
    while (y < 250.0) {
      const double len = lengths[k % 18], h = heights[(k * 7 + side * 3) % 18];
      const double x0 = side == 0 ? -width / 2 - 20.0 : width / 2;
      w.boxes.push_back({Eigen::Vector3d(x0, y, 0.0), Eigen::Vector3d(x0 + 20.0, y + len, h)});
      y += len + gaps[k % 10];
      ++k;
    }
  }
  return w;
}

class OpenSky : public sim::RayCaster {
 public:
  bool cast(const Eigen::Vector3d&, const Eigen::Vector3d&, double, sim::RayHit&) const override { return false; }
};

}  // namespace v2xloc::test
