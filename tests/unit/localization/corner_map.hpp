// A test map: three orthogonal 20 x 7.5 m walls meeting at the origin, points 0.5 m apart (every
// pose constrained), with its k-d tree and normals in heap storage (test side).
#pragma once

#include <memory>
#include <vector>

#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/search/kdtree.hpp"

namespace v2xloc::testing {

struct CornerMap {
  std::vector<Vec3f> points;
  std::unique_ptr<KdTreeStorage<Vec3f, 4096>> tree = std::make_unique<KdTreeStorage<Vec3f, 4096>>();
  std::vector<Vec3f> normals;
  bool normals_ok = false;

  CornerMap() {
    for (int i = 0; i < 40; ++i) {
      for (int j = 0; j < 15; ++j) {
        points.emplace_back(0.5f * i, 0.0f, 0.5f * j);
        points.emplace_back(0.0f, 0.5f * i, 0.5f * j);
        points.emplace_back(0.5f * i, 0.5f * j, 0.0f);
      }
    }
    tree->build(points);
    normals.resize(points.size());
    NormalParams np;
    np.radius = 1.2f;
    normals_ok = estimate_normals(tree->tree, np, normals).status == NormalsStatus::kOk;
  }
  IcpTarget target() const { return IcpTarget{points, normals, &tree->tree, nullptr, nullptr}; }
};

}  // namespace v2xloc::testing
