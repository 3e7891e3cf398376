// The work a 100 ms period has done so far, estimated in instructions from the stages' own counts
// (scan, map clouds fused, odometry and ICP queries, map normals), so that the deferrable work
// (a map rebuild step, the basin audit) takes only what the period has left. Counts, not time:
// the same input schedules the same work on every machine, run after run. The per-unit costs are
// averages measured with callgrind on the x86-64 -O2 host build (TUNING.md, "Period budget");
// they steer the schedule, the worst-case tests check the result.
#pragma once

#include <cstdint>

namespace v2xloc {

struct PeriodWorkParams {
  bool enabled = true;                 // false: fixed quotas only (audit.work_per_period, every rebuild step)
  double budget = 92e6;                // [instructions] target per period (100 M less the estimate's error)
  double scan = 10.5e6;                // [instructions] scan ingest and registration downsampling, per read of the sweep
  // [instructions] per point of a map cloud handed to map fusion: the recordings' ~16k-point clouds
  // cost ~16-22 M; a 131k-point cloud of a synthetic canyon 61 M (priced high: the budget errs
  // towards deferring)
  double map_cloud_point = 1375.0;
  double map_vetting = 12e6;           // [instructions] per other unit the quorum checked after it
  double cells_rebuild = 25e6;         // [instructions] map fusion's reference cells rebuilt
  double background_check = 0.8e6;     // [instructions] a cloud scored on its unit's surveyed background
  double odometry_frame = 0.0;         // [instructions] per frame the odometry registers (its map update, voxelization)
  double odometry_query = 0.0;         // [instructions] per odometry source point and iteration
  double tracking_query = 0.0;         // [instructions] per tracking ICP point and pass
  double evaluation_point = 0.0;       // [instructions] per point of a full-scan fitness evaluation
  double map_normal = 0.0;             // [instructions] per map normal computed on first use
  double rebuild_step = 16e6;          // [instructions] one map rebuild step (extract, or a tree slice)
  double activation = 14e6;            // [instructions] the new map's first normals, in the period it activates
  double search_unit = 0.0;            // [instructions] per pose-search work unit (pose_search.hpp)
  double audit_start = 12e6;           // [instructions] an audit's set-up (road height over the map, score points)
  double search_start = 12e6;          // [instructions] a lost-track search's set-up (road height, proximity grid)
  // [periods] a rebuild step deferred this many periods in a row runs regardless (bounded latency)
  std::uint32_t max_deferred_rebuild_steps = 5;
};

class PeriodWork {
 public:
  void configure(const PeriodWorkParams& params) { params_ = params; spent_ = 0.0; }
  void start_period() { spent_ = 0.0; }
  void add(double instructions) { spent_ += instructions; }
  double spent() const { return spent_; }
  // Instructions left in the period after `also` more (never negative).
  double left(double also = 0.0) const {
    const double l = params_.budget - spent_ - also;
    return l > 0.0 ? l : 0.0;
  }
  const PeriodWorkParams& params() const { return params_; }

 private:
  PeriodWorkParams params_{};
  double spent_ = 0.0;
};

}  // namespace v2xloc
