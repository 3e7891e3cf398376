// The reference map the ego scan registers to: the fused infrastructure and agent clouds
// (map_fusion.hpp) and, double-buffered, the registration target built from them (points, k-d
// tree, vicinity bitmap, normals on first use). Registration reads the active target while the next one is built over several
// periods, at most every refresh_period: infrastructure clouds arrive several times per
// second and the static scene hardly changes between them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"
#include "v2xloc/algo/localization/map_fusion.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/registration/lazy_normals.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/search/proximity_grid.hpp"

namespace v2xloc {

class ReferenceMap {
 public:
  // icp_gate: [m] the tracking ICP's correspondence gate, the vicinity bitmap's reach.
  void configure(const ReferenceMapParams& params, double icp_gate);

  // A cloud within cloud_interval of its source's stored cloud is not fused (kPaced): the
  // next rebuild would take the source's later cloud anyway. A source without a stored cloud (its
  // last one rejected or held back) is paced on its last attempt the same way, so a sender the
  // consistency check keeps refusing costs one check per interval, not one per share. wants() is
  // that test alone, cheap and read-only, so a caller can skip a share's costlier checks (its
  // signature) before insert.
  bool wants(std::uint32_t source_id, double t) const;
  MapInsertResult insert(const MapCloudInput& in);
  // An infrastructure unit's surveyed background (MapFusion::set_background); after configure().
  bool set_background(std::uint32_t source_id, const SurveyedBackground& background) {
    return fusion_.set_background(source_id, background);
  }
  // Expires old clouds and advances the target build; true when a rebuild finished this period.
  // normals: the map normals computed / refused (cap) in the period that ends here.
  // may_build false: expiry only, the build waits (the period has no room for a step).
  bool refresh(double t, LazyNormalCounters& normals, bool may_build = true);
  std::uint32_t steps_run() const { return steps_run_; }  // build steps refresh() ran this period (the first map: all)
  // A build step would run at t (a rebuild in progress, or one due); after refresh() of that period.
  bool build_due(double t) const;
  // The next build step will finish the tree and put the new target to use (its normals are then
  // computed as the registration first asks: a costlier registration that period).
  bool next_step_activates() const;

  bool ready() const { return ready_; }  // the active target has at least min_points
  // Clouds were fused in the period refresh() closed (arrived since the previous scan): its spare
  // work is spent, so a due rebuild waits for a quiet period (at most refresh_quiet_wait) and
  // so does the basin audit.
  bool busy() const { return busy_; }
  IcpTarget target();  // non-const: its normals are computed as the registration asks for them
  std::span<const Vec3f> points() const { return targets_[active_].points.span(); }
  const MapFusion& fusion() const { return fusion_; }

 private:
  struct Target {
    FixedVector<Vec3f, config::kMaxMapPoints> points;
    Vec3f normals[config::kMaxMapPoints];
    KdTreeStorage<Vec3f, config::kMaxMapPoints> tree;
    ProximityGrid vicinity;  // "no map point within the ICP gate": those queries skip the tree
    LazyNormals lazy;        // normals on first use, into `normals`
    std::uint64_t normal_done[(config::kMaxMapPoints + 63) / 64];
  };
  enum class BuildPhase : std::uint8_t { kIdle, kTree };
  static constexpr std::uint32_t kBuildSteps = 2;  // extract, tree (+ vicinity): one rebuild

  // One build step; false: nothing (more) to do this period. finished: the new target is active.
  bool build_step(double t, bool& finished);
  std::size_t tree_quota() const;  // points a tree slice may touch this period (all for the first map)
  void build_vicinity(Target& target) const;
  void activate(Target& next);
  void record_attempt(std::uint32_t source_id, double t);

  ReferenceMapParams params_{};
  double icp_gate_ = 1.0;  // [m]
  MapFusion fusion_{};
  Target targets_[2];
  std::uint32_t active_ = 0;
  BuildPhase phase_ = BuildPhase::kIdle;
  bool tree_started_ = false;        // the next target's tree is being built in slices
  KdBuildResult tree_result_{};
  std::uint64_t build_revision_ = 0;
  std::uint64_t revision_ = ~0ull;
  double built_t_ = -1e300;
  bool ready_ = false;
  bool fused_this_period_ = false;  // a cloud was handed to map fusion since the last refresh()
  std::uint32_t steps_run_ = 0;
  // Last cloud time handed to map fusion per source id (pacing of sources with no stored cloud);
  // full: the oldest entry gives way (pacing then fails open: more checks, never a lost cloud).
  struct Attempt {
    std::uint32_t id = 0;
    double t = 0.0;
    bool used = false;
  };
  static constexpr std::size_t kPacedSources = 2 * config::kMaxMapSources;
  Attempt attempts_[kPacedSources]{};
  bool busy_ = false;
};

}  // namespace v2xloc
