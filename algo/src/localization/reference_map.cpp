#include "v2xloc/algo/localization/reference_map.hpp"

#include <cmath>

#include "v2xloc/algo/registration/normals.hpp"

namespace v2xloc {

void ReferenceMap::configure(const ReferenceMapParams& params, double icp_gate) {
  params_ = params;
  icp_gate_ = icp_gate;
  fusion_.configure(params.fusion);
  targets_[0].points.clear();
  targets_[1].points.clear();
  active_ = 0;
  phase_ = BuildPhase::kIdle;
  tree_started_ = false;
  build_revision_ = 0;
  revision_ = ~0ull;
  built_t_ = -1e300;
  ready_ = false;
  fused_this_period_ = false;
  busy_ = false;
  for (Attempt& a : attempts_) a = Attempt{};
}

bool ReferenceMap::wants(std::uint32_t source_id, double t) const {
  for (const MapSourceInfo& s : fusion_.sources()) {
    // Not newer at all: fusion refuses it as stale (and counts it), at no cost.
    if (s.active && s.id == source_id) return !(t > s.timestamp) || !(t - s.timestamp < params_.cloud_interval);
  }
  for (const Attempt& a : attempts_) {
    if (a.used && a.id == source_id) return !(t - a.t < params_.cloud_interval);  // older than the last: paced too
  }
  return true;
}

void ReferenceMap::record_attempt(std::uint32_t source_id, double t) {
  if (!std::isfinite(t)) return;
  Attempt* slot = nullptr;
  for (Attempt& a : attempts_) {
    if (a.used && a.id == source_id) {
      slot = &a;
      break;
    }
    if (slot == nullptr || !a.used || (slot->used && a.t < slot->t)) slot = &a;  // a free one, else the oldest
  }
  if (slot->used && slot->id == source_id && !(t > slot->t)) return;
  *slot = Attempt{source_id, t, true};
}

MapInsertResult ReferenceMap::insert(const MapCloudInput& in) {
  if (!wants(in.source_id, in.t)) {
    MapInsertResult r;
    r.status = MapInsertStatus::kPaced;
    r.input_points = static_cast<std::uint32_t>(in.points.size());
    return r;
  }
  fused_this_period_ = true;
  record_attempt(in.source_id, in.t);
  return fusion_.insert(in.source_id, in.t, in.world_T_sensor, in.points, !in.is_agent, in.background_fits);
}

IcpTarget ReferenceMap::target() {
  Target& m = targets_[active_];
  return IcpTarget{m.points.span(), std::span<const Vec3f>(m.normals, m.points.size()), &m.tree.tree,
                   params_.vicinity_cell > 0.0f ? &m.vicinity : nullptr, &m.lazy};
}

bool ReferenceMap::refresh(double t, LazyNormalCounters& normals, bool may_build) {
  normals = targets_[active_].lazy.new_period(params_.normals_per_period);
  busy_ = fused_this_period_;
  fused_this_period_ = false;
  steps_run_ = 0;
  fusion_.expire(t);
  if (!may_build && ready_) return false;
  // One build step per period while a map is in use; the first one is built at once.
  const std::uint32_t steps = ready_ ? 1u : kBuildSteps;
  bool finished = false;
  for (std::uint32_t s = 0; s < steps; ++s) {
    const bool more = build_step(t, finished);
    if (more || finished) ++steps_run_;
    if (!more) break;
  }
  return finished;
}

bool ReferenceMap::next_step_activates() const {
  if (phase_ != BuildPhase::kTree || !tree_started_) return false;
  return targets_[1 - active_].tree.tree.build_work_left() <= tree_quota();
}

bool ReferenceMap::build_due(double t) const {
  if (phase_ != BuildPhase::kIdle) return true;
  if (fusion_.revision() == revision_) return false;
  if (ready_ && t - built_t_ < params_.refresh_period) return false;
  // Sources send in bursts: the rebuild waits for the burst to end (all its clouds in one
  // rebuild, none of its periods also extracting), but not forever.
  return !(ready_ && busy_ && t - built_t_ < params_.refresh_period + params_.refresh_quiet_wait);
}

std::size_t ReferenceMap::tree_quota() const {
  return ready_ && params_.tree_work_per_period > 0 ? params_.tree_work_per_period : ~std::size_t{0};
}

// The vicinity bitmap over the map's bounding box, reach = the tracking ICP's gate + 1 cm (the
// ICP asks it only for gates within its reach, less a rounding slack).
void ReferenceMap::build_vicinity(Target& target) const {
  if (!(params_.vicinity_cell > 0.0f)) return;
  Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
  for (const Vec3f& p : target.points) {
    if (!p.allFinite()) continue;
    lo = lo.cwiseMin(p.cast<double>());
    hi = hi.cwiseMax(p.cast<double>());
  }
  ProximityGridParams gp;
  gp.cell = params_.vicinity_cell;
  gp.reach = static_cast<float>(icp_gate_ + 0.01);
  if (!(lo.x() <= hi.x())) {
    target.vicinity.build({}, Vec3d::Zero(), Vec3d::Zero(), gp);  // no finite point: an empty grid
    return;
  }
  target.vicinity.build(target.points.span(), 0.5 * (lo + hi), 0.5 * (hi - lo), gp);
}

// The built target becomes the registration's; its normals start empty (computed on first use).
void ReferenceMap::activate(Target& next) {
  NormalParams np;
  np.radius = params_.normal_radius;
  np.orient_to_viewpoint = false;  // point-to-plane residuals do not care about the sign
  next.lazy.reset(&next.tree.tree, np, std::span<Vec3f>(next.normals, config::kMaxMapPoints),
                  std::span<std::uint64_t>(next.normal_done, (config::kMaxMapPoints + 63) / 64),
                  params_.normals_per_period);
  active_ = 1 - active_;
  revision_ = build_revision_;
  phase_ = BuildPhase::kIdle;
  ready_ = next.points.size() >= params_.min_points;
}

bool ReferenceMap::build_step(double t, bool& finished) {
  Target& next = targets_[1 - active_];
  switch (phase_) {
    case BuildPhase::kIdle:
      if (!build_due(t)) return false;
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
      if (!next.tree.tree.build_step(tree_quota(), tree_result_)) return false;  // more next period
      tree_started_ = false;
      build_vicinity(next);  // O(N + grid words), a few M instructions: in the tree's last slice
      activate(next);
      finished = true;
      return false;
    }
  }
  return false;
}

}  // namespace v2xloc
