#include "v2xloc/algo/localization/reference_map.hpp"

#include "v2xloc/algo/registration/normals.hpp"

namespace v2xloc {

void ReferenceMap::configure(const LocalizerParams& params) {
  params_ = params;
  fusion_.configure(params.map);
  targets_[0].points.clear();
  targets_[1].points.clear();
  active_ = 0;
  phase_ = BuildPhase::kIdle;
  tree_started_ = false;
  normals_done_ = 0;
  build_revision_ = 0;
  revision_ = ~0ull;
  built_t_ = -1e300;
  ready_ = false;
}

MapInsertResult ReferenceMap::insert(const MapCloudInput& in) {
  return fusion_.insert(in.source_id, in.t, in.world_T_sensor.matrix(), in.points, !in.is_agent);
}

IcpTarget ReferenceMap::target() const {
  const Target& m = targets_[active_];
  return IcpTarget{m.points.span(), std::span<const Vec3f>(m.normals, m.points.size()), &m.tree.tree};
}

bool ReferenceMap::refresh(double t) {
  fusion_.expire(t);
  // One build step per period while a map is in use; the first one is built at once.
  const std::uint32_t steps = ready_ ? 1u : kBuildSteps;
  bool finished = false;
  for (std::uint32_t s = 0; s < steps; ++s) {
    if (!build_step(t, finished)) break;
  }
  return finished;
}

bool ReferenceMap::build_step(double t, bool& finished) {
  Target& next = targets_[1 - active_];
  switch (phase_) {
    case BuildPhase::kIdle:
      if (fusion_.revision() == revision_) return false;
      if (ready_ && t - built_t_ < params_.map_refresh_period) return false;
      fusion_.extract(next.points);
      build_revision_ = fusion_.revision();
      built_t_ = t;
      phase_ = BuildPhase::kTree;
      tree_started_ = false;
      tree_result_ = {};
      return true;
    case BuildPhase::kTree: {
      if (!tree_started_) {
        next.tree.begin_build(next.points.span());
        tree_started_ = true;
      }
      const std::size_t quota = ready_ && params_.map_tree_work_per_period > 0 ? params_.map_tree_work_per_period
                                                                              : ~std::size_t{0};
      if (!next.tree.tree.build_step(quota, tree_result_)) return false;  // more next period
      tree_started_ = false;
      normals_done_ = 0;
      phase_ = BuildPhase::kNormals;
      return true;
    }
    case BuildPhase::kNormals: {
      NormalParams np;
      np.radius = params_.map_normal_radius;
      np.orient_to_viewpoint = false;  // point-to-plane residuals do not care about the sign
      const std::size_t n = next.points.size();
      const std::size_t slice = ready_ && params_.map_normals_per_period > 0 ? params_.map_normals_per_period : n;
      estimate_normals_range(next.tree.tree, np, normals_done_, slice,
                             std::span<Vec3f>(next.normals, config::kMaxMapPoints));
      normals_done_ += slice;
      if (normals_done_ < n) return false;  // more next period
      active_ = 1 - active_;
      revision_ = build_revision_;
      phase_ = BuildPhase::kIdle;
      ready_ = next.points.size() >= params_.map_min_points;
      finished = true;
      return false;
    }
  }
  return false;
}

}  // namespace v2xloc
