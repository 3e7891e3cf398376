// Synthetic inputs for the worst-case periods: a street canyon (ground, two facades with
// irregular pillars and poles), an infrastructure LiDAR's view of it, ego scans taken from a pose
// in it, and the adversarial variants (identical points, one plane, a line, a featureless
// corridor, noise, NaN/Inf). Not a renderer: points are sampled on the surfaces near the sensor,
// which is all the localizer's cost depends on (point counts, spatial spread, degeneracy).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "v2xloc/algo/core/types.hpp"

namespace v2xloc::worst_case {

// Deterministic uniform [0, 1) (SplitMix64).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : s_(seed) {}
  double uniform() {
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
  }

 private:
  std::uint64_t s_;
};

enum class Scene { kCanyon, kCorridor, kPlane };

// World points on the scene's surfaces within `radius` of `center` (x, y), `spacing` apart.
inline std::vector<Vec3d> scene_points(Scene scene, const Vec3d& center, double radius, double spacing) {
  std::vector<Vec3d> out;
  const double x0 = center.x() - radius, x1 = center.x() + radius;
  // Ground.
  for (double x = x0; x <= x1; x += spacing) {
    for (double y = -12.0; y <= 12.0; y += spacing) {
      const double dx = x - center.x(), dy = y - center.y();
      if (dx * dx + dy * dy <= radius * radius) out.emplace_back(x, y, 0.0);
    }
  }
  if (scene == Scene::kPlane) return out;
  // Facades at y = +-12 m, 12 m high.
  for (double x = x0; x <= x1; x += spacing) {
    for (double z = 0.0; z <= 12.0; z += spacing) {
      out.emplace_back(x, 12.0, z);
      out.emplace_back(x, -12.0, z);
    }
  }
  if (scene == Scene::kCorridor) return out;
  // Pillars (1 m boxes standing 1.5 m in front of the facades) at irregular spacing, and poles.
  Rng rng(7);
  for (double x = -200.0; x <= 200.0; x += 5.0 + 6.0 * rng.uniform()) {
    if (x < x0 - 1.0 || x > x1 + 1.0) continue;
    const double side = rng.uniform() < 0.5 ? -1.0 : 1.0;
    const double y = side * 10.5;
    for (double z = 0.0; z <= 6.0; z += spacing) {
      for (double t = -0.5; t <= 0.5; t += spacing) {
        out.emplace_back(x + t, y - 0.5, z);
        out.emplace_back(x + t, y + 0.5, z);
        out.emplace_back(x - 0.5, y + t, z);
        out.emplace_back(x + 0.5, y + t, z);
      }
    }
    if (rng.uniform() < 0.5) {
      const double py = -side * (7.0 + 2.0 * rng.uniform());
      for (double z = 0.0; z <= 5.0; z += spacing) {
        for (int k = 0; k < 8; ++k) {
          const double a = k * 0.785398;
          out.emplace_back(x + 0.15 * std::cos(a), py + 0.15 * std::sin(a), z);
        }
      }
    }
  }
  return out;
}

// world_T_sensor^-1 * p, as float.
inline std::vector<Vec3f> to_sensor(const std::vector<Vec3d>& world, const Mat4d& world_T_sensor,
                                    std::size_t max_points) {
  const Mat4d inv = world_T_sensor.inverse();
  std::vector<Vec3f> out;
  const std::size_t stride = world.size() > max_points ? (world.size() + max_points - 1) / max_points : 1;
  for (std::size_t i = 0; i < world.size() && out.size() < max_points; i += stride) {
    const Vec3d q = inv.topLeftCorner<3, 3>() * world[i] + inv.topRightCorner<3, 1>();
    out.push_back(q.cast<float>());
  }
  return out;
}

inline Mat4d pose_xy_yaw(double x, double y, double z, double yaw) {
  Mat4d t = Mat4d::Identity();
  t(0, 0) = std::cos(yaw);
  t(0, 1) = -std::sin(yaw);
  t(1, 0) = std::sin(yaw);
  t(1, 1) = std::cos(yaw);
  t(0, 3) = x;
  t(1, 3) = y;
  t(2, 3) = z;
  return t;
}

}  // namespace v2xloc::worst_case
