// Bounding volume hierarchy over static primitives: median split on the widest centroid axis,
// small leaves, near-child-first stack traversal that prunes with the best hit so far.
#pragma once

#include "host_sim/world/primitives.hpp"

#include <cstdint>
#include <vector>

namespace v2xloc::sim {

class Bvh {
 public:
  void build(const std::vector<Primitive>& prims);
  // Closest hit among the primitives in (0, t_max]; returns primitive index or -1.
  int closest(const std::vector<Primitive>& prims, const Ray& ray, double t_max, double& t,
              Eigen::Vector3d& normal) const;
  std::size_t node_count() const { return nodes_.size(); }

 private:
  struct Node {
    Aabb box;
    std::uint32_t first = 0;  // leaf: first index into order_; inner: left child (right = left + 1)
    std::uint32_t count = 0;  // > 0 for leaves
  };
  std::uint32_t build_node(const std::vector<Aabb>& boxes, std::uint32_t begin, std::uint32_t end);
  std::vector<Node> nodes_;
  std::vector<std::uint32_t> order_;
};

}  // namespace v2xloc::sim
