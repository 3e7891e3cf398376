// The one question the GNSS model and every sensor ask the world: what does this ray hit first?
// Frame: local ENU at the intersection centre (x east, y north, z up), metres.
#pragma once

#include <Eigen/Core>

namespace v2xloc::sim {

struct RayHit {
  double range = 0.0;                                    // metres along the unit direction
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();      // unit surface normal at the hit
  int material = 0;                                      // world-defined surface class
  int object_id = -1;                                    // which primitive/object was hit
};

class RayCaster {
 public:
  virtual ~RayCaster() = default;
  // Nearest hit along origin + s * dir for s in (0, max_range], dir a unit vector.
  virtual bool cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range,
                    RayHit& hit) const = 0;
};

}  // namespace v2xloc::sim
